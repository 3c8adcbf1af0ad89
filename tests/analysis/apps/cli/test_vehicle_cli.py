"""``rcsim vehicle check``: the printout an analyst reads before flying a vehicle.

Oracles: the canted example's jet matrix from its documented arithmetic (jet_01, quad A
forward jet: force 22.24 N x (cos 10 deg, -sin 10 deg cos 45 deg, -sin 10 deg sin 45 deg) =
(21.902, -2.731, -2.731) N; torque (r - CG) x F with r - CG = (1.0, 0.9, 0.9) m =
(0, 22.443, -22.443) N m); on the paper vehicle, the +roll jets are 2 and 4 (Table 2), one
couple at arm r = 0.812 m: authority 2 F r / Ixx = 2 x 22.24 x 0.812 / 3583.09 rad/s^2
= 0.5775 deg/s^2, and losing both loses +roll.
"""

from __future__ import annotations

import numpy as np
import pytest

from rcsim.analysis.apps.cli import main


def test_canted_check(capsys):
    assert main(["vehicle", "check", "canted16", "--no-pairs"]) == 0
    out = capsys.readouterr().out
    row = next(line for line in out.splitlines() if line.startswith("jet_01 "))
    assert row.split()[1:7] == ["21.902", "-2.731", "-2.731", "0.000", "22.443", "-22.443"]
    assert "Unreachable directions: none" in out
    assert "0 of 16 single jets out lose an axis direction" in out


def test_canted12_check(capsys):
    """Oracle for jet_01 (triad A, forward): as canted16's jet_01 (same corner, same canted
    forward direction); jet_04 (triad B, aft): force 22.24 N x (-cos 10 deg, sin 10 deg cos 45
    deg, -sin 10 deg sin 45 deg) = (-21.902, 2.731, -2.731) N at r - CG = (1.0, -0.9, 0.9) m:
    torque (r - CG) x F = (0, -16.981, -16.981) N m.  Every axis direction is reachable, and
    no single jet or pair of jets out loses one (the LP of ``rcsim vehicle check``)."""
    assert main(["vehicle", "check", "canted12"]) == 0
    out = capsys.readouterr().out
    rows = {line.split()[0]: line.split()[1:7] for line in out.splitlines() if line[:4] == "jet_"}
    assert rows["jet_01"] == ["21.902", "-2.731", "-2.731", "0.000", "22.443", "-22.443"]
    assert rows["jet_04"] == ["-21.902", "2.731", "-2.731", "0.000", "-16.981", "-16.981"]
    assert "12 jets" in out and "Unreachable directions: none" in out
    assert "0 of 12 single jets out lose an axis direction" in out
    assert "Two jets out: 0 of 66 pairs lose an axis direction" in out


def test_paper_check_authority(capsys):
    assert main(["vehicle", "check", "paper"]) == 0
    out = capsys.readouterr().out
    roll = next(line for line in out.splitlines() if line.startswith("+roll"))
    expect = np.degrees(2 * 22.24 * 0.812 / 3583.09)
    assert float(roll.split()[1]) == round(expect, 4)
    # Two roll jets of the same sign out leave no +roll (jets 2 and 4 are the +roll jets)
    assert "jet_02+jet_04" in out


def test_unreachable_axis_is_reported(tmp_path, capsys):
    text = (
        "[mass]\nmass_kg = 100.0\ncg_m = [0.0, 0.0, 0.0]\ninertia_kg_m2 = [10.0, 10.0, 10.0]\n"
        "[jet_defaults]\nthrust_n = 10.0\n"
        "[[jet]]\nposition_m = [1.0, 0.0, 0.0]\ndirection = [0, 1, 0]\n"
        "[[jet]]\nposition_m = [1.0, 0.0, 0.0]\ndirection = [0, -1, 0]\n"
    )
    (tmp_path / "v.toml").write_text(text)
    assert main(["vehicle", "check", str(tmp_path / "v.toml")]) == 0
    out = capsys.readouterr().out
    status = {
        line.split()[0]: line.split()[1] for line in out.splitlines() if line.startswith(("+", "-"))
    }
    assert status["+roll"] == status["-pitch"] == "UNREACHABLE"
    assert status["+yaw"] != "UNREACHABLE"
    assert "Unreachable directions: +roll, -roll, +pitch, -pitch" in out


def test_long_jet_names_keep_the_columns_and_couples_are_said_once(capsys):
    """Issue 18 review: the review's 10-jet bus (corpus/files/mybus10.toml), whose jet names
    run to 13 characters: every row of the force/torque table has its numbers under the
    header's columns (each number ends where its header ends), and its pure-couple authority
    is 0 in every direction (the authority table), said once rather than on each jet-out line.
    """
    from pathlib import Path

    vehicle = Path(__file__).parent / "corpus" / "files" / "mybus10.toml"
    assert main(["vehicle", "check", str(vehicle), "--no-pairs"]) == 0
    lines = capsys.readouterr().out.splitlines()
    header = next(line for line in lines if line.startswith("jet ") and "Fx" in line)
    ends = [header.index(c) + len(c) for c in ("Fx", "Fy", "Fz", "Tx", "Ty", "Tz")]
    rows = [line for line in lines if line.startswith(("aft_", "fwd_"))]
    assert len(rows) == 10
    for row in rows:
        numbers = row.split()[1:7]
        at = [row.index(n, e - len(n) - 1) + len(n) for n, e in zip(numbers, ends)]
        assert at == ends, row
    said = [line for line in lines if "already has no pure couple" in line]
    assert len(said) == 1 and "+roll, -roll, +pitch, -pitch, +yaw, -yaw" in said[0]
    jet_out = [line for line in lines if " loses: " in line]
    assert len(jet_out) == 10 and not any("+roll" in line for line in jet_out)


def test_no_pairs_says_the_pairs_were_not_searched(capsys):
    # Issue 31: --no-pairs printed "0 of 66 pairs lose an axis direction" about a search it
    # skipped.
    assert main(["vehicle", "check", "canted12", "--no-pairs"]) == 0
    out = capsys.readouterr().out
    assert "Two jets out: not searched (the 66 pairs were skipped)" in out
    assert "pairs lose" not in out


def test_many_jets_are_estimated_and_refused_before_the_work(tmp_path, capsys, monkeypatch):
    # Issue 31: 1,000 jets (499,500 pair LPs) ran with no estimate.  The estimate is the LP
    # count (rcsim.spacecraft.vehicle.authority.lp_count) times a rate timed on the
    # vehicle; 60 jets with pairs are 30 + 60 x 24 + 1,770 x 6 = 12,090 LPs.  A rate of 1 s
    # per LP (patched: the clock of the machine is not the test's) puts it over 30 minutes.
    import rcsim.analysis.apps.estimates as estimates
    import rcsim.spacecraft.vehicle.authority as authority

    assert authority.lp_count(60, pairs=True) == 12_090
    assert authority.lp_count(60, pairs=False) == 1_470
    jets = "".join(
        f"[[jet]]\nposition_m = [1.0, {np.cos(a):.4f}, {np.sin(a):.4f}]\n"
        f"direction = [0, {-np.sin(a) * s:.4f}, {np.cos(a) * s:.4f}]\n"
        for a, s in zip(np.linspace(0, 2 * np.pi, 60, endpoint=False), [1, -1] * 30)
    )
    (tmp_path / "v.toml").write_text(
        "[mass]\nmass_kg = 100.0\ncg_m = [0.0, 0.0, 0.0]\ninertia_kg_m2 = [10.0, 10.0, 10.0]\n"
        "[jet_defaults]\nthrust_n = 1.0\n" + jets
    )
    clock = iter(range(0, 30_000, 3))  # three LPs timed between two calls: 1 s per LP
    monkeypatch.setattr(estimates.time, "perf_counter", lambda: float(next(clock)))
    monkeypatch.setattr(authority, "check_vehicle", lambda *a, **k: pytest.fail("checked"))
    assert main(["vehicle", "check", str(tmp_path / "v.toml")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "60 jets" in err and "1,770 two-jets-out pairs" in err
    assert "3.4 h" in err and "--yes" in err and "--no-pairs" in err  # 12,090 s


def test_paper_check_prints_translation_coupling(capsys):
    """The paper's jets are pure couples: every mode costs the same and leaves no delta-v;
    +roll costs the couple's propellant per deg/s, 2 mdot t with t = Ixx (1 deg/s) / (2 F r):
    Ixx / (r Isp g0) x (pi / 180) = 3583.09 / (0.812 x 280 x 9.80665) x 0.017453 = 0.02805 kg
    (Table 1's Ixx, Table 2's arm, rcsim's Isp 280 s)."""
    assert main(["vehicle", "check", "paper", "--no-pairs"]) == 0
    out = capsys.readouterr().out
    assert "Translation coupling per allocation mode" in out
    section = out.split("Translation coupling per allocation mode")[1]
    rows = [line.split() for line in section.splitlines() if line.strip().startswith("+roll ")]
    assert [r[1] for r in rows] == ["propellant", "propellant+translation", "translation-first"]
    for r in rows:
        assert float(r[2]) == pytest.approx(
            3583.09 / (0.812 * 280 * 9.80665) * np.pi / 180, rel=1e-3
        )
        assert float(r[3]) == 0.0


def test_check_prints_the_pulse_model_and_minimum_impulse_bit(tmp_path, capsys):
    """Paper vehicle, 10 ms minimum on-time, first-order pulse tau_r = 8 ms, tau_t = 12 ms:
    the bit's full-thrust time is ``u - tau_r (1 - e^(-u/tau_r)) + p tau_t (1 - e^-20)``,
    ``p = 1 - e^(-u/tau_r)`` (docs/vehicles.md, "Pulses"), and its +roll rate change that
    times the +roll authority ``2 F r / Ixx`` (the oracle above), to the 3 digits printed."""
    from rcsim.spacecraft.vehicle.definition import packaged_vehicle

    text = packaged_vehicle("paper").read_text(encoding="utf-8")
    text = text.replace("min_on_s = 0.0 ", "min_on_s = 0.010 ", 1)
    text += '\n[pulse]\nmodel = "exponential"\nrise_s = 0.008\ntail_s = 0.012\n'
    (tmp_path / "v.toml").write_text(text, encoding="utf-8")
    assert main(["vehicle", "check", str(tmp_path / "v.toml"), "--no-pairs"]) == 0
    out = capsys.readouterr().out
    assert "pulses: first-order rise tau 8 ms, tail-off tau 12 ms" in out
    u, r, t = 0.010, 0.008, 0.012
    p = 1 - np.exp(-u / r)
    full_s = u - r * p + p * t * (1 - np.exp(-20.0))
    line = next(x for x in out.splitlines() if x.startswith("minimum impulse bit"))
    assert f"{full_s / u * 100:.3g} % of a square" in line
    roll = float(line.split("+roll ")[1].split(",")[0])
    alpha_deg = np.degrees(2 * 22.24 * 0.812 / 3583.09)
    assert roll == float(f"{alpha_deg * full_s:.3g}")


def test_check_of_a_square_pulse_vehicle_says_so(capsys):
    """canted12 has no [pulse] and a 10 ms minimum on-time: the bit is the square pulse, its
    rate change the printed authority times 10 ms (to the digits printed)."""
    assert main(["vehicle", "check", "canted12", "--no-pairs"]) == 0
    out = capsys.readouterr().out
    assert "pulses: square (no [pulse])" in out
    line = next(x for x in out.splitlines() if x.startswith("minimum impulse bit"))
    assert "(min_on_s = 10 ms, 100 % of a square pulse's impulse)" in line
    authority = next(x for x in out.splitlines() if x.startswith("+yaw"))
    yaw = float(line.split("+yaw ")[1].split(",")[0])
    assert yaw == float(f"{float(authority.split()[1]) * 0.010:.3g}")
