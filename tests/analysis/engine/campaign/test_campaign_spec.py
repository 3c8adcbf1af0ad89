"""Campaign spec validation: every mistake is one line naming the key, and leaves no directory."""

import math

import numpy as np
import pytest

from rcsim.analysis.apps.cli import main
from rcsim.analysis.engine.campaign.spec import EXAMPLE_SPEC, load_spec
from rcsim.models.errors import InputError
from rcsim.spacecraft.guards import history_bytes

# Longest run: one run's record must fit a chunk's budget of 192 MiB; a run of the packaged
# vehicle (16 jets) records history_bytes(1, 1) bytes per 40 ms cycle (232 bytes of History
# arrays + 8 of the time column today: 838,860 cycles = 33,554 s).
MAX_DURATION_S = (192 * 2**20 // history_bytes(1, 1, n_jets=16)) * 0.040

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
    spec = load_spec(
        _write(
            tmp_path,
            MINIMAL.replace("[scenario]", "[[scenario]]")
            + """
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
""".replace("[controller]", "[controller]", 1),
        )
    )
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
    spec = load_spec(
        _write(tmp_path, MINIMAL.replace('"phase-plane"', '"lookup"\ntable = "mytable.csv"'))
    )
    assert spec.table == str((tmp_path / "mytable.csv").resolve())
    assert spec.resolved["controller"]["table_sha256"]


def test_paper_tables_by_name(tmp_path):
    """``table = "table6"`` / ``"table7"`` load the installed package's copies of the paper's
    Tables 6 / 7 (rcsim/models/tables PAPER_LOOKUP_TABLES), recorded by name with the SHA-256 of
    the packaged file's bytes (oracle: the file read through importlib.resources)."""
    import hashlib
    from importlib.resources import files

    from rcsim.models.tables import PAPER_LOOKUP_TABLES

    assert set(PAPER_LOOKUP_TABLES) == {"table6", "table7"}
    for name, filename in PAPER_LOOKUP_TABLES.items():
        spec = load_spec(
            _write(tmp_path, MINIMAL.replace('"phase-plane"', f'"lookup"\ntable = "{name}"'))
        )
        assert spec.table == name
        packaged = (files("rcsim.models") / "data" / filename).read_bytes()
        assert spec.resolved["controller"] == {
            "name": "lookup",
            "table": name,
            "table_sha256": hashlib.sha256(packaged).hexdigest(),
        }
    # A name is for the lookup controller only, like a path.
    with pytest.raises(
        InputError, match="controller.table: is only for the lookup and adaptive controllers"
    ):
        load_spec(
            _write(tmp_path, MINIMAL.replace('"phase-plane"', '"phase-plane"\ntable = "table6"'))
        )


def test_a_file_named_like_a_paper_table_needs_dot_slash(tmp_path):
    from rcsim.models.tables import load_lookup_table

    load_lookup_table(which="table7").to_csv(tmp_path / "table6")
    text = MINIMAL.replace('"phase-plane"', '"lookup"\ntable = "table6"')
    with pytest.raises(
        InputError, match='ambiguous: both the packaged paper table .* write "./table6"'
    ):
        load_spec(_write(tmp_path, text))
    spec = load_spec(_write(tmp_path, text.replace('"table6"', '"./table6"')))
    assert spec.table == str((tmp_path / "table6").resolve())


def test_controller_names_are_the_registry_list(tmp_path):
    """One list of controller names (rcsim.lookup.registry.ALL_CONTROLLERS, the adaptive
    controller included): the spec accepts each and its error lists them."""
    from rcsim.lookup.registry import ALL_CONTROLLERS

    assert "adaptive" in ALL_CONTROLLERS
    for name in ALL_CONTROLLERS:
        spec = load_spec(_write(tmp_path, MINIMAL.replace('"phase-plane"', f'"{name}"')))
        assert spec.controller == name
    listed = "controller.name: must be one of " + ", ".join(ALL_CONTROLLERS)
    with pytest.raises(InputError, match=listed):
        load_spec(_write(tmp_path, MINIMAL.replace('"phase-plane"', '"pid"')))


BAD = [
    (
        "unknown key",
        MINIMAL + "[dispersions.thrust]\nthree_sigma = 2\n",
        "unknown key 'dispersions.thrust'",
    ),
    (
        "unknown nested key",
        MINIMAL + "[dispersions.three_sigma]\nthrust = 2\n",
        "unknown key 'dispersions.three_sigma.thrust'",
    ),
    (
        "negative sigma",
        MINIMAL + "[dispersions.three_sigma]\nthrust_n = -2\n",
        "dispersions.three_sigma.thrust_n: must be >= 0",
    ),
    ("negative scale", MINIMAL + "[dispersions]\nscale = -1\n", "dispersions.scale: must be >= 0"),
    (
        "zero runs",
        MINIMAL.replace("runs_per_case = 3", "runs_per_case = 0"),
        "runs_per_case: must be an integer >= 1",
    ),
    (
        "missing table file",
        MINIMAL.replace('"phase-plane"', '"lookup"\ntable = "nope.csv"'),
        "controller.table: file not found",
    ),
    # Sensors, timing and faults (issue 11): the file, the table and the key in every message.
    (
        "sensor key typo",
        MINIMAL + "[dispersions.sensor]\nnoise_deg = 0.01\n",
        "spec.toml: [dispersions.sensor]: unknown key(s) noise_deg",
    ),
    (
        "negative sensor noise",
        MINIMAL + "[dispersions.sensor]\nrate_noise_deg_s = -0.01\n",
        "[dispersions.sensor]: rate_noise_deg_s must be finite and >= 0, got -0.01",
    ),
    (
        "sensor noise of two axes",
        MINIMAL + "[dispersions.sensor]\natt_noise_deg = [1, 2]\n",
        "[dispersions.sensor]: att_noise_deg must be a number or 3 numbers",
    ),
    (
        "sensor not a table",
        MINIMAL + "[dispersions]\nsensor = 0.01\n",
        "[dispersions.sensor]: expected a table, got 0.01",
    ),
    (
        "negative delay",
        MINIMAL + "[dispersions.timing]\nopen_delay_s = -0.001\n",
        "[dispersions.timing]: open_delay_s must be a number >= 0 [s], got -0.001",
    ),
    # 0.030 + 0.008 + 5 x 0.001 = 0.043 s: beyond the 40 ms cycle (a command must act in it).
    (
        "delays beyond the cycle",
        MINIMAL + "[dispersions.timing]\ncommand_delay_s = 0.030\n"
        "open_delay_s = 0.008\nopen_delay_sigma_s = 0.001\n",
        "[dispersions.timing]: command_delay_s + open_delay_s + 5 x their sigmas is 0.043 s",
    ),
    (
        "fault mode typo",
        MINIMAL + "[dispersions.fault]\nmode = 'failed'\n",
        "[dispersions.fault]: mode must be one of none, off, stuck, degraded, got 'failed'",
    ),
    (
        "fault jet 17",
        MINIMAL + "[dispersions.fault]\nmode = 'off'\njets = [13, 17]\n",
        "[dispersions.fault]: jets: no jet 17: the paper's vehicle has 16 jets, numbered "
        "1..16 (got [13, 17])",
    ),
    (
        "thrust factor above 1",
        MINIMAL + "[dispersions.fault]\nmode = 'degraded'\nthrust_factor = 1.2\n",
        "[dispersions.fault]: thrust_factor must be [lo, hi]",
    ),
    (
        "table for phase-plane",
        MINIMAL.replace('"phase-plane"', '"phase-plane"\ntable = "table6"'),
        "controller.table: is only for the lookup and adaptive controllers",
    ),
    (
        "unknown controller",
        MINIMAL.replace('"phase-plane"', '"pid"'),
        "controller.name: must be one of",
    ),
    ("bad case", MINIMAL.replace("[13]", "[27]"), "scenario.cases: no such rate case 27"),
    ("typo top level", "sead = 3\n" + MINIMAL, "unknown key 'sead'"),
    ("no scenario", "seed = 1\n[controller]\nname = 'lookup'\n", "scenario: missing"),
    ("bad toml", "seed = \n", "not valid TOML"),
    (
        "zero threshold",
        MINIMAL + "[failure]\nrate_error_deg_s = 0\n",
        "failure.rate_error_deg_s: must be > 0",
    ),
    (
        "bad histories",
        MINIMAL + "[output]\nhistories = 'some'\n",
        "output.histories: must be one of",
    ),
    # Valid types, physically absurd values (issue 8): refused with the range and its reason.
    # Table 5 and Table 1 (issue 18's inertia rule, rcsim.spacecraft.dispersions "Physical
    # tensors"): the smallest second moment of mass is (3160.22 + 2457.06 - 3583.09) / 2 =
    # 1017.095 kg m^2 and sqrt((322.48^2 + 284.42^2 + 221.13^2) / 4) = 241.757 kg m^2, so
    # scale < 4.207 (below the single-entry bound, Ixx: 3583.09 / 322.48 = 11.11).
    (
        "absurd scale",
        MINIMAL + "[dispersions]\nscale = 1e300\n",
        "dispersions.scale: must be < 4.207 with these 3-sigma values",
    ),
    (
        "scale just too large",
        MINIMAL + "[dispersions]\nscale = 4.21\n",
        "dispersions.scale: must be < 4.207",
    ),
    (
        "scale beyond both bounds: the binding one (the tensor) is named",
        MINIMAL + "[dispersions]\nscale = 11.2\n",
        "second moment of mass, tr(I)/2 - its largest principal moment = 1017 kg m^2",
    ),
    # Issue 18: CG y, z and products of inertia (keys beyond Table 5).  The paper's farthest
    # jets are 1 m from the CG (jets 5, 6 along x, 7, 8 along z: rcsim/models/vehicle/README.md).
    (
        "cg_y beyond the jets",
        MINIMAL + "[dispersions.three_sigma]\ncg_y_m = 1.01\n",
        "dispersions.three_sigma.cg_y_m: times scale 1 it must be below 1 m, the distance from "
        "the nominal CG to the farthest jet",
    ),
    (
        "negative cg_z",
        MINIMAL + "[dispersions.three_sigma]\ncg_z_m = -0.01\n",
        "dispersions.three_sigma.cg_z_m: must be >= 0",
    ),
    # sqrt(1017.095^2 - 241.757^2) = 987.93 kg m^2: the most Ixy may be with Table 5's moments.
    (
        "product of inertia that can break the triangle inequality",
        MINIMAL + "[dispersions.three_sigma]\nixy_kg_m2 = 1000.0\n",
        "dispersions.three_sigma.ixy_kg_m2: sqrt((Ixx^2 + Iyy^2 + Izz^2)/4 + Ixy^2",
    ),
    (
        "override beyond nominal thrust",
        MINIMAL + "[dispersions.three_sigma]\nthrust_n = 22.24\n",
        "dispersions.three_sigma.thrust_n: times scale 1 it must be below 22.24 N",
    ),
    (
        "tilt beyond 90 deg",
        MINIMAL + "[dispersions.three_sigma]\nthruster_angle_deg = 90\n",
        "dispersions.three_sigma.thruster_angle_deg: times scale 1 it must be below 90 deg",
    ),
    # A roll pair: 2 x 22.24 N x 0.812 m = 36.12 N m (rcsim/models/vehicle/README.md geometry).
    (
        "absurd disturbance",
        MINIMAL.replace("cases = [13]", "kind = 'hold'\ndisturbance_n_m = [0, 0, 1e300]"),
        "scenario.disturbance_n_m: each component must be within the jets' largest torque about "
        "that axis, +-[36.12, 34.52, 32.2] N m",
    ),
    (
        "absurd initial rate",
        MINIMAL.replace("cases = [13]", "kind = 'hold'\ninitial_rate_deg_s = [1e6, 0, 0]"),
        "scenario.initial_rate_deg_s: magnitude must be <= 3 deg/s",
    ),
    (
        "absurd duration",
        MINIMAL.replace("duration_s = 1.0", "duration_s = 1e9"),
        f"scenario.duration_s: must be <= {MAX_DURATION_S:.0f} s",
    ),
    (
        "campaign too large for the disk",
        MINIMAL.replace("runs_per_case = 3", "runs_per_case = 1_000_000_000_000"),
        "runs_per_case = 1000000000000: the campaign's 1,000,000,000,000 runs need about",
    ),
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
    for extra, message in (
        (["--runs-per-case", "0"], "--runs-per-case must be >= 1"),
        (["--workers", "0"], "--workers must be >= 1"),
        (["--workers", "2", "--scheduler", "tcp://x:1"], "not allowed with"),
    ):
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
    for resume in ([], ["--resume"]):
        assert main(["campaign", "run", str(spec), "--out", str(out), *resume]) == 2
        assert "not a campaign directory" in capsys.readouterr().err
    other = _write(tmp_path, MINIMAL.replace("seed = 2", "seed = 3"), "other.toml")
    done = tmp_path / "done"
    assert main(["campaign", "run", str(spec), "--out", str(done), "--no-progress"]) == 0
    capsys.readouterr()
    # A campaign's directory is never replaced: without --resume it is refused.
    assert main(["campaign", "run", str(spec), "--out", str(done)]) == 2
    err = capsys.readouterr().err
    assert f"--out {done}: holds a campaign (complete); resume it" in err, err
    assert main(["campaign", "run", str(other), "--out", str(done), "--resume"]) == 2
    assert "spec differs" in capsys.readouterr().err


def test_parse_errors_raise_input_error(tmp_path):
    with pytest.raises(InputError, match="cannot read"):
        load_spec(tmp_path / "missing.toml")


def test_ranges_accept_their_edges(tmp_path):
    """The ranges refuse only beyond them: Table 5 at 4.2x (beyond the paper's 3x of Figs
    13-14; the inertia rule's limit is 4.207, see BAD), a hold disturbance of 36 N m about roll
    and an initial rate of 3 deg/s load."""
    spec = load_spec(
        _write(
            tmp_path,
            MINIMAL.replace(
                "cases = [13]",
                "kind = 'hold'\ndisturbance_n_m = [36.0, 0, 0]\ninitial_rate_deg_s = [0, 0, 3.0]",
            )
            + "[dispersions]\nscale = 4.2\n",
        )
    )
    assert spec.cases[0].disturbance_n_m[0] == 36.0
    assert spec.sigmas.thrust_n == pytest.approx(2.0 / 3 * 4.2)
    # Ixy up to 987.93 kg m^2 with Table 5's moments at scale 1 (BAD's arithmetic).
    loaded = load_spec(_write(tmp_path, MINIMAL + "[dispersions.three_sigma]\nixy_kg_m2 = 987.0\n"))
    assert loaded.sigmas.products_kg_m2 == (987.0 / 3, 0.0, 0.0)


def test_spec_with_utf8_byte_order_mark_is_read(tmp_path):
    """A BOM (Windows editors) is not TOML syntax; the spec reads as without it."""
    plain = load_spec(_write(tmp_path, MINIMAL))
    path = tmp_path / "bom.toml"
    path.write_bytes(b"\xef\xbb\xbf" + MINIMAL.encode())
    assert load_spec(path).resolved == plain.resolved


def test_spec_that_is_not_utf8_is_one_line_error(tmp_path):
    path = tmp_path / "latin1.toml"
    path.write_bytes(MINIMAL.replace("seed = 2", "# caf\xe9\nseed = 2").encode("latin-1"))
    with pytest.raises(InputError, match="not a UTF-8 text file"):
        load_spec(path)


def test_runner_errors_name_its_own_parameters():
    """The library names ``workers`` / ``scheduler`` (the CLI shows them as flags)."""
    from rcsim.analysis.engine.campaign.runner import connect

    with pytest.raises(InputError) as err:
        connect(2, "tcp://x:1")
    assert err.value.parameter == "workers" and "exclusive" in str(err.value)
    with pytest.raises(InputError) as err:
        connect(0, None)
    assert err.value.parameter == "workers" and str(err.value) == "workers must be >= 1, got 0"


def test_hold_limits_come_from_the_vehicle_flown(tmp_path):
    """Issue 27: a hold's disturbance limit is the flown vehicle's own largest torque about each
    axis (the sum of its jets' torques of one sign at nominal thrust: 4 quads x 2 jets x 440 N
    x 2 m = 3,520 N m for docs/examples/service16.toml), never the paper's 36 N m; and the
    initial-rate limit keeps the validated rotation per physics step (3 deg/s x 40 ms,
    docs/convergence.md) for the vehicle's own step."""
    from rcsim.spacecraft.vehicle import resolve_vehicle

    examples = resolve_vehicle("paper").parents[3] / "docs" / "examples"
    hold = MINIMAL.replace("cases = [13]", "kind = 'hold'\ndisturbance_n_m = [0, 0, {d}]")
    hold = hold.replace('name = "phase-plane"', 'name = "allocator"')  # flies any layout

    def spec(vehicle: str, d: float, extra: str = ""):
        text = f'vehicle = "{vehicle}"\n' + hold.format(d=d).replace(
            "duration_s", extra + "duration_s"
        )
        return load_spec(_write(tmp_path, text))

    service = str(examples / "service16.toml")
    assert spec(service, 100.0).cases[0].disturbance_n_m[2] == 100.0  # the paper's would refuse
    with pytest.raises(InputError, match=r"\+-\[3520, 3520, 3520\] N m"):
        spec(service, 3600.0)
    with pytest.raises(InputError, match=r"disturbance_n_m: .*\+-\[0.1035, 0.3087, 0.3087\] N m"):
        spec(str(examples / "smallsat8.toml"), 1.0)  # the paper's 36 N m would accept it
    fine = tmp_path / "fine_step.toml"
    fine.write_text(
        resolve_vehicle("paper").read_text().replace("timestep_s = 0.04 ", "timestep_s = 0.02 ")
    )
    rate = "initial_rate_deg_s = [0, 0, {w}]\n"
    assert spec(str(fine), 1.0, rate.format(w=6.0)).cases[0].omega0_rad_s[2] == pytest.approx(
        math.radians(6.0)
    )
    with pytest.raises(InputError, match=r"must be <= 6 deg/s, .* 20 ms physics step"):
        spec(str(fine), 1.0, rate.format(w=6.1))
