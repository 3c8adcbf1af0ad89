"""``rcsim maneuver`` end to end: outputs, and bad input handled as a user error.

Contract (rcsim/analysis/apps/cli/maneuver.py, issue 2): a run writes DIR/history.parquet with one
row per 40 ms control cycle and the required columns, plus the Fig 1-2 style PNGs; a user mistake
prints one line on stderr, exits 2, shows no traceback and creates no output directory.

Most calls go through ``rcsim.analysis.apps.cli.main`` in-process (fast); one subprocess call runs
the installed ``rcsim`` executable to prove the entry point.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from rcsim.analysis.apps.cli import main

REQUIRED = [
    "t_s",
    "att_err_roll_deg",
    "att_err_pitch_deg",
    "att_err_yaw_deg",
    "rate_roll_deg_s",
    "rate_pitch_deg_s",
    "rate_yaw_deg_s",
] + [f"jet_{j:02d}_on_s" for j in range(1, 17)]
PNGS = ("attitude_error.png", "rates_jets.png")
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
CYCLE_S = 0.04


def rcsim_executable() -> str:
    exe = Path(sys.executable).with_name("rcsim")
    return str(exe) if exe.exists() else (shutil.which("rcsim") or "rcsim")


def assert_user_error(rc, err, out_dir: Path):
    assert rc == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("rcsim: error:"), err
    assert "Traceback" not in err
    assert not out_dir.exists()
    # Not even the hidden temporary directory of the atomic write is left behind.
    assert not any(p.name.startswith(f".{out_dir.name}") for p in out_dir.parent.iterdir())


def test_maneuver_writes_history_and_plots(tmp_path, capsys):
    out = tmp_path / "m"
    rc = main(
        [
            "maneuver",
            "--controller",
            "phase-plane",
            "--attitude-deg",
            "5",
            "5",
            "5",
            "--duration-s",
            "2",
            "--out",
            str(out),
        ]
    )
    captured = capsys.readouterr()
    assert rc == 0, captured.err
    frame = pd.read_parquet(out / "history.parquet")
    missing = [c for c in REQUIRED if c not in frame.columns]
    assert not missing
    # One row per control cycle from t = 0.
    assert len(frame) == 50
    np.testing.assert_allclose(frame["t_s"], np.arange(50) * CYCLE_S, atol=1e-12)
    # Degrees at this boundary: the initial error of a +5 deg command is -5 deg on each axis.
    np.testing.assert_allclose(
        frame.loc[0, ["att_err_roll_deg", "att_err_pitch_deg", "att_err_yaw_deg"]].to_numpy(float),
        -5.0,
        atol=1e-9,
    )
    # The start firing is in the first cycle, in seconds of on-time per cycle (<= 40 ms).
    jets = frame[[f"jet_{j:02d}_on_s" for j in range(1, 17)]].to_numpy()
    assert jets[0].max() == pytest.approx(CYCLE_S)
    assert jets.min() >= 0 and jets.max() <= CYCLE_S
    for name in PNGS:
        data = (out / name).read_bytes()
        assert data.startswith(PNG_MAGIC) and len(data) > 5_000
    assert "final attitude error" in captured.out


def test_rcsim_executable_entry_point(tmp_path):
    out = tmp_path / "exe"
    proc = subprocess.run(
        [
            rcsim_executable(),
            "maneuver",
            "--attitude-deg",
            "0",
            "0",
            "5",
            "--duration-s",
            "0.4",
            "--out",
            str(out),
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    assert (out / "history.parquet").is_file()
    assert all((out / p).is_file() for p in PNGS)


@pytest.mark.parametrize(
    "argv",
    [
        ["--bogus-option"],
        ["--duration-s", "-5"],
        ["--duration-s", "0"],
        ["--duration-s", "nan"],
        ["--duration-s", "ten"],
        ["--controller", "bang-bang"],
        ["--table", "x.csv"],  # --table is only for the lookup controller
    ],
    ids=[
        "unknown-option",
        "negative-duration",
        "zero-duration",
        "nan-duration",
        "non-numeric-duration",
        "unknown-controller",
        "table-with-phase-plane",
    ],
)
def test_bad_input_is_one_line_exit_2_no_output(tmp_path, capsys, argv):
    out = tmp_path / "never"
    rc = main(["maneuver", "--attitude-deg", "5", "5", "5", "--out", str(out), *argv])
    assert_user_error(rc, capsys.readouterr().err, out)


def test_missing_attitude_is_user_error(tmp_path, capsys):
    out = tmp_path / "never"
    rc = main(["maneuver", "--attitude-deg", "5", "5", "--out", str(out)])
    assert_user_error(rc, capsys.readouterr().err, out)


@pytest.mark.parametrize(
    "content", ["", "case,jet_01\n1,abc\n", None], ids=["empty", "garbage", "missing-file"]
)
def test_bad_table_file_is_user_error(tmp_path, capsys, content):
    table = tmp_path / "bad.csv"
    if content is not None:
        table.write_text(content)
    out = tmp_path / "never"
    rc = main(
        [
            "maneuver",
            "--controller",
            "lookup",
            "--table",
            str(table),
            "--attitude-deg",
            "5",
            "5",
            "5",
            "--duration-s",
            "1",
            "--out",
            str(out),
        ]
    )
    assert_user_error(rc, capsys.readouterr().err, out)


def test_out_missing_parents_are_created(tmp_path, capsys):
    out = tmp_path / "no" / "such" / "dir"
    rc = main(["maneuver", "--attitude-deg", "1", "0", "0", "--duration-s", "1", "--out", str(out)])
    assert rc == 0
    assert (out / "history.parquet").is_file()


def test_out_dir_with_foreign_files_is_never_replaced(tmp_path, capsys):
    """An existing directory rcsim did not write (e.g. --out ~) is refused, not wiped."""
    out = tmp_path / "mine"
    out.mkdir()
    (out / "thesis.tex").write_text("precious")
    rc = main(["maneuver", "--attitude-deg", "1", "0", "0", "--duration-s", "1", "--out", str(out)])
    err = capsys.readouterr().err
    assert rc == 2 and len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert os.listdir(out) == ["thesis.tex"]


MANEUVER = ["maneuver", "--attitude-deg", "1", "0", "0", "--duration-s", "0.4"]


def test_out_dir_of_an_earlier_maneuver_is_replaced_only_with_overwrite(tmp_path, capsys):
    out = tmp_path / "again"
    assert main([*MANEUVER, "--out", str(out)]) == 0
    before = (out / "summary.json").read_text()
    # Issue 8: replacing even our own output is explicit; the refusal says how.
    rc = main(
        ["maneuver", "--attitude-deg", "2", "0", "0", "--duration-s", "0.4", "--out", str(out)]
    )
    err = capsys.readouterr().err
    assert rc == 2 and len(err.strip().splitlines()) == 1 and "--overwrite" in err
    assert (out / "summary.json").read_text() == before
    assert (
        main(
            [
                "maneuver",
                "--attitude-deg",
                "2",
                "0",
                "0",
                "--duration-s",
                "0.4",
                "--out",
                str(out),
                "--overwrite",
            ]
        )
        == 0
    )
    assert (out / "summary.json").read_text() != before
    assert sorted(os.listdir(tmp_path)) == ["again"]  # no temporary or old copies left
    marker = (out / ".rcsim-output").read_text().splitlines()
    assert marker[0] == "written by rcsim maneuver"
    # Issue 31: the record lists what the command wrote, and nothing else is there.
    assert json.loads(marker[1])["files"] == sorted(p for p in os.listdir(out) if p[0] != ".")


@pytest.mark.parametrize("overwrite", [[], ["--overwrite"]], ids=["plain", "overwrite"])
def test_campaign_directory_is_never_replaced(tmp_path, capsys, overwrite):
    """Issue 8: `rcsim maneuver --out RUNS` replaced a campaign (cases.csv gone)."""
    runs = tmp_path / "runs"
    runs.mkdir()
    (runs / ".rcsim-output").write_text("written by rcsim campaign run\n")
    (runs / "cases.csv").write_text("case,runs,failed\nroll,1,0\n")
    rc = main([*MANEUVER, "--out", str(runs), *overwrite])
    err = capsys.readouterr().err
    assert rc == 2 and len(err.strip().splitlines()) == 1
    assert str(runs) in err and "campaign run" in err
    assert sorted(os.listdir(runs)) == [".rcsim-output", "cases.csv"]
    assert sorted(os.listdir(tmp_path)) == ["runs"]


def test_output_directory_honours_the_umask(tmp_path):
    # Issue 8: mkdtemp's 0700 leaked into the final directory; new directories get
    # 0o777 & ~umask like any other tool's (POSIX mkdir(2)).
    old = os.umask(0o027)
    try:
        assert main([*MANEUVER, "--out", str(tmp_path / "m")]) == 0
    finally:
        os.umask(old)
    assert (tmp_path / "m").stat().st_mode & 0o777 == 0o750


def test_unwritable_out_is_one_line_before_the_flight(capsys, monkeypatch):
    # /proc refuses new entries even to root, so this holds for every user (issue 8:
    # "--out /proc/x dies with FileNotFoundError").
    if not os.path.isdir("/proc/self"):
        pytest.skip("no /proc on this system")
    import rcsim.analysis.engine.flight as flight

    def must_not_fly(*args, **kwargs):
        raise AssertionError("flew before checking --out")

    monkeypatch.setattr(flight, "fly", must_not_fly)
    rc = main([*MANEUVER, "--out", "/proc/rcsim-x"])
    err = capsys.readouterr().err
    assert rc == 2 and len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert err.startswith("rcsim: error: --out /proc/rcsim-x: cannot create it in /proc")


def test_os_error_while_writing_is_one_line_naming_the_path(tmp_path, capsys, monkeypatch):
    # A disk filling up during the write: the OS's reason and the path, exit 2, nothing left.
    import errno

    import rcsim.analysis.engine.plots as plots

    target = tmp_path / "m"

    def disk_full(frame, path, **kwargs):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))

    monkeypatch.setattr(plots, "plot_attitude_error", disk_full)
    rc = main([*MANEUVER, "--out", str(target)])
    err = capsys.readouterr().err
    assert rc == 2 and len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert os.strerror(errno.ENOSPC) in err and "attitude_error.png" in err
    assert list(tmp_path.iterdir()) == []


def test_marker_of_an_older_rcsim_is_never_replaced(tmp_path, capsys):
    # Issue 31: a marker without a record of outputs (an older rcsim's) proves nothing about
    # what the directory holds: --overwrite refuses it, naming why, and deletes nothing.
    out = tmp_path / "old"
    out.mkdir()
    (out / ".rcsim-output").write_text(
        "written by rcsim; this directory is replaced by the next run\n"
    )
    (out / "summary.json").write_text("{}\n")
    assert main([*MANEUVER, "--out", str(out)]) == 2
    assert "--overwrite" in capsys.readouterr().err
    assert main([*MANEUVER, "--out", str(out), "--overwrite"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "lists no outputs" in err
    assert sorted(os.listdir(out)) == [".rcsim-output", "summary.json"]


def test_lookup_generate_creates_parents_and_replaces_only_with_overwrite(tmp_path, capsys):
    # Issue 8: `lookup generate --out gen/T.csv` refused a missing parent that every other
    # command creates, and `--out notes.csv` silently replaced an unrelated file.
    table = tmp_path / "gen" / "sub" / "T.csv"
    argv = ["lookup", "generate", "--out", str(table), "--compare-with", "none"]
    assert main(argv) == 0
    assert table.is_file() and table.with_name("T_settling.csv").is_file()
    table.write_text("edited by hand\n")
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "--overwrite" in err and str(table) in err
    assert table.read_text() == "edited by hand\n"
    assert main([*argv, "--overwrite"]) == 0
    assert table.read_text().startswith("case,")
    assert sorted(p.name for p in table.parent.iterdir()) == ["T.csv", "T_settling.csv"]


def test_cli_draws_with_the_file_backend(tmp_path):
    # Issue 8: the backend is chosen by the CLI (it only writes files), not by importing a
    # plotting module; a user's MPLBACKEND does not reach the CLI's figures.
    code = (
        "import matplotlib; from rcsim.analysis.apps.cli import main; "
        "assert main(['scenario', 'list']) == 0; print(matplotlib.get_backend())"
    )
    proc = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        timeout=120,
        env={**os.environ, "MPLBACKEND": "svg"},
    )
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split()[-1].lower() == "agg"


def test_maneuver_of_a_twelve_jet_vehicle_file(tmp_path, capsys):
    """``--vehicle canted12 --controller allocator``: the history has one on-time column per
    jet of that vehicle (12), and the summary's propellant is what those columns burn.
    Oracle: propellant = sum over jets and cycles of on-time x 22.24 N / (Isp g0), Isp 280 s
    (canted12.toml; no dispersion in a maneuver, no delay: every command is delivered), to
    1e-12 relative; the maneuver ends inside the maneuver limit, 0.6 deg (Table 4), below
    which the allocator holds attitude by its rate loop (docs/vehicles.md)."""
    out = tmp_path / "m"
    argv = ["maneuver", "--vehicle", "canted12", "--controller", "allocator"]
    rc = main([*argv, "--attitude-deg", "0", "0", "5", "--duration-s", "40", "--out", str(out)])
    assert rc == 0, capsys.readouterr().err
    frame = pd.read_parquet(out / "history.parquet")
    jets = [c for c in frame.columns if c.startswith("jet_") and c.endswith("_on_s")]
    assert jets == [f"jet_{j:02d}_on_s" for j in range(1, 13)]
    import json

    summary = json.loads((out / "summary.json").read_text())
    burnt = frame[jets].to_numpy().sum() * 22.24 / (280.0 * 9.80665)
    assert summary["propellant_kg"] == pytest.approx(burnt, rel=1e-12)
    assert np.linalg.norm(summary["final_att_err_deg"]) < 0.6
    assert "canted-triads-12" in capsys.readouterr().out


def test_maneuver_says_when_the_propellant_ran_out(tmp_path, capsys):
    """Issue 18 review: a maneuver whose propellant runs out says so and when, in
    summary.json and on stdout, as a campaign's failure reason does.  Oracle: 2 g of
    propellant is used up (``propellant_kg`` = 0.002 kg to 1e-9 relative, the exact
    exhaustion instant of rcsim.spacecraft.propellant), the history's commands go on after the
    instant (the allocator never reaches the attitude), and none of them is counted:
    ``firings`` equals the new firings (a command > 0 to a jet that did not fill the
    previous cycle) in the cycles starting before it."""
    import json

    from rcsim.spacecraft.vehicle import resolve_vehicle

    text = resolve_vehicle("canted12").read_text()
    vehicle = tmp_path / "dry.toml"
    vehicle.write_text(text.replace("mass_kg = 40.0", "mass_kg = 0.002", 1))
    out = tmp_path / "m"
    argv = ["maneuver", "--vehicle", str(vehicle), "--controller", "allocator"]
    rc = main([*argv, "--attitude-deg", "0", "0", "5", "--duration-s", "20", "--out", str(out)])
    assert rc == 0, capsys.readouterr().err
    summary = json.loads((out / "summary.json").read_text())
    t_out = summary["propellant_exhausted_s"]
    assert 0 < t_out < 20
    assert summary["reason"] == f"propellant exhausted at t = {t_out:.4f} s"
    assert not summary["sim_failed"]
    assert summary["propellant_kg"] == pytest.approx(0.002, rel=1e-9)
    assert f"propellant exhausted at t = {t_out:.4f} s" in capsys.readouterr().out
    frame = pd.read_parquet(out / "history.parquet")
    on = frame.filter(regex=r"^jet_\d\d_on_s$").to_numpy()
    full = on >= CYCLE_S * (1 - 1e-12)
    starts = (on > 0) & ~np.vstack([np.zeros((1, on.shape[1]), bool), full[:-1]])
    before = frame["t_s"].to_numpy() < t_out
    assert summary["firings"] == starts[before].sum()
    assert starts[~before].sum() > 0
