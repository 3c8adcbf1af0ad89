"""``rcsim vehicle check`` on a vehicle with slosh and appendages: the modes section, and the
modes' warnings."""

from __future__ import annotations

import re

from rcsim.analysis.apps.cli import main
from rcsim.spacecraft.vehicle import resolve_vehicle

EXAMPLES = resolve_vehicle("paper").parents[3] / "docs" / "examples"


def test_check_prints_each_mode(capsys):
    """canted16_modes: the hub is the file's 3505 kg less 12 + 30 + 30 kg of modes = 3433 kg;
    each slide's clamped frequency is the file's 0.35 Hz on 12 kg; each wing's inertia about
    its hinge is I_xx + m d^2 = 15 + 30 x 1.6^2 = 91.8 kg m^2 at the file's 0.4 Hz; with the
    hub free every coupled frequency is above the lowest clamped one and its effective mass
    below the clamped (the hub moves against the mode: Rayleigh's quotient with a smaller
    mass)."""
    assert main(["vehicle", "check", str(EXAMPLES / "canted16_modes.toml"), "--no-pairs"]) == 0
    out = capsys.readouterr().out
    assert "Warnings: none" in out
    section = out[out.index("Modes (linearised about rest") :]
    assert "hub (the rigid part): 3433 kg" in section
    rows = {
        line.split()[0]: line.split()[1:]
        for line in section.splitlines()
        if line.startswith("  tank_") or line.startswith("  wing_")
    }
    assert set(rows) == {
        "tank_lateral_1",
        "tank_lateral_2",
        "wing_plus_y_hinge",
        "wing_minus_y_hinge",
    }
    for name, parts in rows.items():
        slide = name.startswith("tank")
        # unit, clamped Hz, mass, its unit (kg | kg m^2), effective mass, its unit
        unit, clamped, mass = parts[:3]
        effective = parts[4] if slide else parts[5]
        assert unit == ("m" if slide else "rad")
        assert " ".join(parts[3:5] if not slide else parts[3:4]) == ("kg" if slide else "kg m^2")
        assert float(clamped) == (0.35 if slide else 0.4)
        assert float(mass) == (12.0 if slide else 91.8)
        assert float(effective) < float(mass)
    coupled = [float(f) for f in re.findall(r"([\d.]+) Hz \(", section)]
    assert len(coupled) == 4 and min(coupled) > 0.35


def test_modes_warnings(capsys, tmp_path):
    """An undamped mode never settles; a clamped frequency of 1.5 Hz at a 40 ms step has 16.7
    steps a period, under the 20 the warning asks for."""
    text = (EXAMPLES / "canted16_modes.toml").read_text(encoding="utf-8")
    text = text.replace("frequency_hz = 0.35", "frequency_hz = 1.5")
    text = text.replace("damping_ratio = 0.005", "damping_ratio = 0.0", 1)
    path = tmp_path / "v.toml"
    path.write_text(text, encoding="utf-8")
    assert main(["vehicle", "check", str(path), "--no-pairs"]) == 0
    out = capsys.readouterr().out
    assert "tank_lateral: clamped frequency 1.5 Hz has 16.7 physics steps a period" in out
    assert "tank_lateral: no damping: the mode never settles once excited" in out


def test_check_states_the_modal_dispersions(capsys, tmp_path):
    """A block's *_3sigma keys are stated, 3-sigma as given, for that mode only; the example
    without them states none."""
    text = (EXAMPLES / "canted16_modes.toml").read_text(encoding="utf-8")
    text = text.replace(
        "damping_ratio = 0.005\n", "damping_ratio = 0.005\nfrequency_hz_3sigma = 0.06\n", 1
    )
    path = tmp_path / "v.toml"
    path.write_text(text, encoding="utf-8")
    assert main(["vehicle", "check", str(path), "--no-pairs"]) == 0
    lines = [line for line in capsys.readouterr().out.splitlines() if "dispersed (3-sigma" in line]
    assert lines == [
        "  tank_lateral dispersed (3-sigma, each run its own): clamped frequency 0.06 Hz"
    ]
    assert main(["vehicle", "check", str(EXAMPLES / "canted16_modes.toml"), "--no-pairs"]) == 0
    assert "dispersed (3-sigma" not in capsys.readouterr().out
