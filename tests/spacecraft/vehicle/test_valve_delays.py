"""A vehicle file's valve timing (issue 18: "valve delays if wanted"): the keys, and what a
jet with them delivers.

Oracles
-------
* The timing model (:mod:`rcsim.spacecraft.valves`, ``docs/faults.md``): a pulse commanded over
  ``[0, t]`` from a cycle's start thrusts over ``[d + o, d + t + c]`` -- the command delay
  ``d`` (``[timing] command_delay_s``), the jet's opening latency ``o`` and closing latency
  ``c`` (``open_delay_s``, ``close_delay_s``) -- and not at all when that interval is empty
  (``t <= o - c``).  So a jet fired from rest for ``t`` delivers the impulse of an on-interval
  shifted by ``d + o`` and lengthened by ``c - o``: ``F max(0, t + c - o)``.  Impulses are
  thrust times on-time sums: 1e-12 relative.  Each cycle's delivered time is that interval's
  overlap with the cycle: 1e-12 s.
* Rigid-body mechanics about a principal axis (as ``tests/spacecraft/test_valves.py``): the
  jets below torque one principal axis each, so from rest the rate change is
  ``tau max(0, t + c - o) / I`` with no gyroscopic term; RK4 on pieces cut at the switch
  instants integrates a constant torque exactly, so 1e-9 relative (rounding is ~1e-15).
"""

from __future__ import annotations

import numpy as np
import pytest

from rcsim.lookup.open_loop import OpenLoopController
from rcsim.models.errors import InputError
from rcsim.spacecraft.navigation import Guidance
from rcsim.spacecraft.simulation import simulate_batch
from rcsim.spacecraft.vehicle import PACKAGED_VEHICLES, Vehicle, load_vehicle

CYCLE_S = 0.04
COMMAND_S = 0.006
OPEN_S, CLOSE_S = 0.008, 0.005  # [jet_defaults]: opening slower than closing
OWN_OPEN_S, OWN_CLOSE_S = 0.003, 0.012  # jet 2's own

#: Two jets about the CG at the origin: jet 1 torques +x (arm 1 m along y, force along z),
#: jet 2 +y (arm 1 m along z, force along x); the inertia is diagonal, so each torques a
#: principal axis.
VEHICLE = f"""
[mass]
mass_kg = 100.0
cg_m = [0.0, 0.0, 0.0]
inertia_kg_m2 = [10.0, 20.0, 25.0]
[timing]
command_delay_s = {COMMAND_S}
[jet_defaults]
thrust_n = 10.0
open_delay_s = {OPEN_S}
close_delay_s = {CLOSE_S}
[[jet]]
position_m = [0.0, 1.0, 0.0]
direction = [0, 0, 1]
[[jet]]
position_m = [0.0, 0.0, 1.0]
direction = [1, 0, 0]
thrust_n = 7.0
open_delay_s = {OWN_OPEN_S}
close_delay_s = {OWN_CLOSE_S}
"""


@pytest.fixture(scope="module")
def delayed(tmp_path_factory) -> Vehicle:
    path = tmp_path_factory.mktemp("delays") / "v.toml"
    path.write_text(VEHICLE)
    return Vehicle.load(path)


def test_keys_default_override_and_record(delayed):
    d = delayed.definition
    assert d.command_delay_s == COMMAND_S
    np.testing.assert_array_equal(d.open_delays_s(), [OPEN_S, OWN_OPEN_S])
    np.testing.assert_array_equal(d.close_delays_s(), [CLOSE_S, OWN_CLOSE_S])
    assert d.delay_keys == ("command_delay_s", "open_delay_s", "close_delay_s")
    assert d.delay_record() == {
        "command_delay_s": COMMAND_S,
        "open_delay_s": [OPEN_S, OWN_OPEN_S],
        "close_delay_s": [CLOSE_S, OWN_CLOSE_S],
    }
    timing = delayed.timing(3)
    assert timing is not None and timing.open_delay_s.shape == (3, 2)
    np.testing.assert_array_equal(timing.close_delay_s[2], [CLOSE_S, OWN_CLOSE_S])


@pytest.mark.parametrize("name", PACKAGED_VEHICLES)
def test_a_vehicle_without_the_keys_flies_without_timing(name):
    """The packaged vehicles give no delay: no timing is passed to any flight, so they fly
    the code path they always flew (byte-identical results: docs/vehicles.md)."""
    vehicle = Vehicle.load(name)
    assert vehicle.definition.delay_keys == () and not vehicle.definition.has_delays
    assert vehicle.timing(4) is None


def test_zero_delays_given_are_given_but_fly_as_none(tmp_path):
    """Keys written as 0 state the vehicle's timing (a campaign may not restate it) and fly
    exactly as no timing."""
    path = tmp_path / "v.toml"
    path.write_text(VEHICLE.replace(str(OWN_OPEN_S), "0.0").replace(str(OWN_CLOSE_S), "0.0")
                    .replace(str(OPEN_S), "0.0").replace(str(CLOSE_S), "0.0")
                    .replace(str(COMMAND_S), "0.0"))  # fmt: skip
    vehicle = Vehicle.load(path)
    assert vehicle.definition.delay_keys == ("command_delay_s", "open_delay_s", "close_delay_s")
    assert vehicle.timing(2) is None


def _flight(vehicle: Vehicle, jet: int, on_s: np.ndarray):
    n = on_s.size
    total = np.zeros((n, 2))
    total[:, jet] = on_s
    return simulate_batch(
        vehicle.nominal(n),
        OpenLoopController(total, CYCLE_S),
        Guidance.rate(np.zeros((n, 3))),
        0.2,
        vehicle=vehicle,
        nthread=1,
    )


#: From nothing to four cycles: 2 ms (shorter than jet 1's open - close, never opens), within a
#: cycle, exactly a cycle (a full-cycle command continues into the next cycle and closes
#: there), and across cycle boundaries.
ON_S = np.array([0.002, 0.0171, 0.04, 0.0937, 0.12])


@pytest.mark.parametrize(
    ("jet", "open_s", "close_s", "axis"),
    [(0, OPEN_S, CLOSE_S, 0), (1, OWN_OPEN_S, OWN_CLOSE_S, 1)],
)
def test_a_delayed_jet_delivers_the_shifted_lengthened_interval(
    delayed, jet, open_s, close_s, axis
):
    hist = _flight(delayed, jet, ON_S)
    assert not hist.failed.any()
    start = COMMAND_S + open_s
    end = COMMAND_S + ON_S + close_s
    thrust_s = np.maximum(0.0, end - start)  # = max(0, t + c - o)
    assert thrust_s[0] == 0.0 if jet == 0 else thrust_s[0] > 0
    force = delayed.definition.thrusts_n()[jet]
    np.testing.assert_allclose(hist.propulsion.on_time_s[:, jet], thrust_s, rtol=1e-12, atol=0)
    np.testing.assert_allclose(
        hist.propulsion.impulse_ns[:, jet], force * thrust_s, rtol=1e-12, atol=0
    )
    # Cycle by cycle: the interval [d + o, d + t + c] cut at the cycle boundaries.
    k = np.arange(hist.delivered_s.shape[1])
    overlap = np.clip(
        np.minimum(end[:, None], (k + 1) * CYCLE_S) - np.maximum(start, k * CYCLE_S), 0, None
    )
    np.testing.assert_allclose(hist.delivered_s[:, :, jet], overlap, rtol=0, atol=1e-12)
    assert (hist.delivered_s[:, :, 1 - jet] == 0).all()
    # The commands stay the commands: the history's on-times are what was asked for.
    np.testing.assert_allclose(hist.on_time_s[:, :, jet].sum(axis=1), ON_S, rtol=1e-12)
    # Euler about a principal axis: tau (t + c - o) / I.
    tau = delayed.force_torque()[3 + axis, jet]
    inertia = delayed.definition.inertia_kg_m2[axis, axis]
    np.testing.assert_allclose(
        hist.final.omega_B[:, axis], tau * thrust_s / inertia, rtol=1e-9, atol=1e-15
    )


def test_maneuver_flies_the_vehicles_delays(delayed):
    """`rcsim maneuver --vehicle` flies through :func:`rcsim.analysis.engine.flight.fly`: the jets
    deliver what the delays make of the commands (the delivered record exists only with
    timing, faults or a thrust profile)."""
    from rcsim.analysis.engine.flight import Scenario, fly

    hist = fly(
        Scenario("step", 1.0, rate_cmd_rad_s=np.radians([0.05, 0.0, 0.0])),
        "allocator",
        vehicle=delayed,
    )
    assert hist.delivered_s is not None
    commanded = hist.on_time_s.sum(axis=1)[0, 0]
    assert commanded > 0
    assert hist.propulsion.on_time_s[0, 0] < commanded  # each opening loses o - c = 3 ms


@pytest.mark.parametrize(
    ("edit", "expect"),
    [
        (("open_delay_s = 0.008", "open_delay_s = -0.001"), ["jet_defaults.open_delay_s", ">= 0"]),
        (("close_delay_s = 0.005", "close_delay_s = 5.0"), ["jet_defaults.close_delay_s", "40 ms"]),
        (
            ("close_delay_s = 0.012", "close_delay_s = 0.036"),
            ["jet[2].close_delay_s", "command_delay_s", "0.042", "0.036"],
        ),
        (("command_delay_s = 0.006", "command_delay_s = 0.04"), ["timing.command_delay_s", "40"]),
        (
            ("command_delay_s = 0.006", "command_delay_s = 0.006\nopen_delay_s = 0.01"),
            ["timing.open_delay_s", "per jet"],
        ),
    ],
)
def test_bad_delays_are_one_line_naming_the_key(tmp_path, edit, expect):
    path = tmp_path / "v.toml"
    text = VEHICLE.replace(*edit)
    assert text != VEHICLE
    path.write_text(text)
    with pytest.raises(InputError) as err:
        load_vehicle(path)
    message = str(err.value)
    assert "\n" not in message and str(path) in message
    for part in expect:
        assert part in message
