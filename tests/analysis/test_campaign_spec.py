"""Campaign spec validation: every mistake is one line naming the key, and leaves no directory."""
import math

import numpy as np
import pytest

from rcsim.analysis.campaign.spec import EXAMPLE_SPEC, load_spec
from rcsim.analysis.cli import main
from rcsim.models.errors import InputError

MINIMAL = """
seed = 2
runs_per_case = 3
[scenario]
cases = [13]
duration_s = 1.0
[controller]
name = "phase-plane"
"""


def _write(tmp_path, text, name="spec.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_example_spec_is_printed_and_valid(tmp_path, capsys):
    assert main(["campaign", "example"]) == 0
    printed = capsys.readouterr().out
    assert printed == EXAMPLE_SPEC
    spec = load_spec(_write(tmp_path, printed))
    assert spec.n_cases == 26 and spec.runs_per_case == 100
    assert spec.controller == "lookup" and spec.table is None
    # Table 5 defaults, one sigma = three-sigma / 3, in SI.
    assert spec.sigmas.thrust_n == pytest.approx(2.0 / 3)
    assert spec.sigmas.thruster_angle_rad == pytest.approx(math.radians(5.0) / 3)
    assert spec.rate_threshold_rad_s == pytest.approx(math.radians(0.04))


def test_overrides_scale_and_scenario_list(tmp_path):
    spec = load_spec(_write(tmp_path, MINIMAL.replace("[scenario]", "[[scenario]]") + """
[[scenario]]
kind = "maneuver"
attitude_deg = [0, 0, 5]
duration_s = 30
name = "yaw5"
[[scenario]]
kind = "hold"
disturbance_n_m = [0, 0, 1.5]
[dispersions]
scale = 3.0
[dispersions.three_sigma]
thrust_n = 1.0
cg_x_m = 0
""".replace("[controller]", "[controller]", 1)))
    assert [c.name for c in spec.cases] == ["rate-13", "yaw5", "hold"]
    assert np.allclose(spec.cases[1].att_cmd_rad, [0, 0, math.radians(5)])
    assert spec.cases[1].duration_s == 30.0
    assert spec.sigmas.thrust_n == pytest.approx(1.0)  # 1.0 / 3 * 3
    assert spec.sigmas.cg_x_m == 0.0
    assert spec.sigmas.mass_kg == pytest.approx(73.6)  # Table 5 73.6 / 3 * 3
    assert spec.n_runs == 9


def test_lookup_table_path_is_relative_to_spec(tmp_path):
    from rcsim.models.tables import load_lookup_table

    load_lookup_table(which="table7").to_csv(tmp_path / "mytable.csv")
    spec = load_spec(_write(tmp_path, MINIMAL.replace('"phase-plane"', '"lookup"\ntable = "mytable.csv"')))
    assert spec.table == str((tmp_path / "mytable.csv").resolve())
    assert spec.resolved["controller"]["table_sha256"]


BAD = [
    ("unknown key", MINIMAL + "[dispersions.thrust]\nthree_sigma = 2\n",
     "unknown key 'dispersions.thrust'"),
    ("unknown nested key", MINIMAL + "[dispersions.three_sigma]\nthrust = 2\n",
     "unknown key 'dispersions.three_sigma.thrust'"),
    ("negative sigma", MINIMAL + "[dispersions.three_sigma]\nthrust_n = -2\n",
     "dispersions.three_sigma.thrust_n: must be >= 0"),
    ("negative scale", MINIMAL + "[dispersions]\nscale = -1\n", "dispersions.scale: must be >= 0"),
    ("zero runs", MINIMAL.replace("runs_per_case = 3", "runs_per_case = 0"),
     "runs_per_case: must be an integer >= 1"),
    ("missing table file", MINIMAL.replace('"phase-plane"', '"lookup"\ntable = "nope.csv"'),
     "controller.table: file not found"),
    ("sensor noise", MINIMAL + "[dispersions.sensor]\nrate_noise_deg_s = 0.01\n",
     "dispersions.sensor: sensor noise and delays are not supported yet"),
    ("unknown controller", MINIMAL.replace('"phase-plane"', '"pid"'), "controller.name: must be one of"),
    ("bad case", MINIMAL.replace("[13]", "[27]"), "scenario.cases: no such rate case 27"),
    ("typo top level", "sead = 3\n" + MINIMAL, "unknown key 'sead'"),
    ("no scenario", "seed = 1\n[controller]\nname = 'lookup'\n", "scenario: missing"),
    ("bad toml", "seed = \n", "not valid TOML"),
    ("zero threshold", MINIMAL + "[failure]\nrate_error_deg_s = 0\n", "failure.rate_error_deg_s: must be > 0"),
    ("bad histories", MINIMAL + "[output]\nhistories = 'some'\n", "output.histories: must be one of"),
]


@pytest.mark.parametrize("what,text,message", BAD, ids=[b[0] for b in BAD])
def test_bad_spec_is_one_line_error_and_no_output(tmp_path, capsys, what, text, message):
    spec = _write(tmp_path, text)
    out = tmp_path / "campaign"
    assert main(["campaign", "run", str(spec), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert message in err, err
    assert str(spec) in err  # names the file
    assert err.count("\n") == 1 and "Traceback" not in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["spec.toml"]  # no debris


def test_cli_option_errors_leave_no_output(tmp_path, capsys):
    spec = _write(tmp_path, MINIMAL)
    out = tmp_path / "campaign"
    for extra, message in ((["--runs-per-case", "0"], "--runs-per-case must be >= 1"),
                           (["--workers", "0"], "--workers must be >= 1"),
                           (["--workers", "2", "--scheduler", "tcp://x:1"], "exclusive")):
        assert main(["campaign", "run", str(spec), "--out", str(out), *extra]) == 2
        assert message in capsys.readouterr().err
        assert not out.exists()


def test_existing_directory_needs_resume_and_same_spec(tmp_path, capsys):
    spec = _write(tmp_path, MINIMAL)
    out = tmp_path / "campaign"
    out.mkdir()
    (out / "something").write_text("x")
    assert main(["campaign", "run", str(spec), "--out", str(out), "--resume"]) == 2
    assert "rcsim did not write" in capsys.readouterr().err
    (out / ".rcsim-output").write_text("")  # an rcsim output, but not a campaign
    assert main(["campaign", "run", str(spec), "--out", str(out)]) == 2
    assert "use --resume" in capsys.readouterr().err
    assert main(["campaign", "run", str(spec), "--out", str(out), "--resume"]) == 2
    assert "not a campaign directory" in capsys.readouterr().err
    other = _write(tmp_path, MINIMAL.replace("seed = 2", "seed = 3"), "other.toml")
    done = tmp_path / "done"
    assert main(["campaign", "run", str(spec), "--out", str(done), "--no-progress"]) == 0
    capsys.readouterr()
    assert main(["campaign", "run", str(other), "--out", str(done), "--resume"]) == 2
    assert "spec differs" in capsys.readouterr().err


def test_parse_errors_raise_input_error(tmp_path):
    with pytest.raises(InputError, match="cannot read"):
        load_spec(tmp_path / "missing.toml")
