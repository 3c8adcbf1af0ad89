"""``[dispersions.sensor|timing|fault]`` read at the input edge: SI specs out, one clear error
per bad value (file, table, key and value named), never a traceback.

Oracle: the keys and ranges of ``rcsim.analysis.engine.campaign.effects`` (``docs/faults.md``); the
malformed values are those of issue 17's harness (strings, nested lists, inline tables,
windows beyond any run).
"""

import numpy as np
import pytest

from rcsim.analysis.engine.campaign.effects import (
    fault_spec,
    parse_effects,
    sensor_spec,
    timing_spec,
)
from rcsim.models.errors import InputError

WHERE = "spec.toml: [dispersions.fault]"


def test_sensor_keys_in_degrees_become_radians():
    # Oracle: the unit in the key's name (deg, deg/s) and pi/180.
    spec = sensor_spec(
        {"att_noise_deg": [0.1, 0.2, 0.3], "rate_walk_deg_s_per_sqrt_s": 0.01},
        "spec.toml: [dispersions.sensor]",
    )
    np.testing.assert_allclose(spec.att_noise_rad, np.radians([0.1, 0.2, 0.3]), rtol=0, atol=0)
    np.testing.assert_array_equal(spec.rate_walk_rad_s_per_sqrt_s, np.radians([0.01] * 3))
    assert not spec.rate_noise_rad_s.any()


def test_timing_and_fault_keys_are_seconds_and_windows():
    t = timing_spec({"open_delay_s": 0.008, "open_delay_sigma_s": 0.001}, "s: [t]")
    assert (t.open_delay_s, t.open_delay_sigma_s, t.close_delay_s) == (0.008, 0.001, 0.0)
    f = fault_spec(
        {"mode": "stuck", "jets": [13, 15], "time_s": 2.0, "stuck_for_s": [0.1, 0.5]},
        WHERE,
        longest_s=20.0,
        n_jets=16,
    )
    assert (f.time_s, f.stuck_for_s, f.jets) == ((2.0, 2.0), (0.1, 0.5), (13, 15))
    # Without jets: every jet of the campaign's vehicle is a candidate.
    assert fault_spec({"mode": "off"}, WHERE, longest_s=20.0, n_jets=12).jets == tuple(range(1, 13))


def test_fault_jets_are_those_of_the_campaigns_vehicle():
    """Jet 13 exists on the 16-jet paper vehicle, not on a 12-jet one: the message names the
    key, the jet, the vehicle and its count."""
    assert fault_spec({"mode": "off", "jets": [13]}, WHERE, 20.0, 16).jets == (13,)
    with pytest.raises(InputError) as err:
        fault_spec({"mode": "off", "jets": [1, 13]}, WHERE, 20.0, 12, "vehicle canted12")
    assert str(err.value) == (
        "spec.toml: [dispersions.fault]: jets: no jet 13: vehicle canted12 has 12 jets, "
        "numbered 1..12 (got [1, 13])"
    )


@pytest.mark.parametrize(
    "table, key",
    [
        ({"mode": "melted"}, "mode"),
        ({"mode": ["off"]}, "mode"),
        ({"mode": "off", "jets": [0]}, "jets"),
        ({"mode": "off", "jets": [[13]]}, "jets"),
        ({"mode": "off", "jets": 13}, "jets"),
        ({"mode": "off", "time_s": "soon"}, "time_s"),
        ({"mode": "off", "time_s": ["a", "b"]}, "time_s"),
        ({"mode": "off", "time_s": [[0.0, 1.0]]}, "time_s"),
        ({"mode": "off", "time_s": {"a": 1}}, "time_s"),
        ({"mode": "off", "time_s": [1e300, 1e300]}, "time_s"),
        ({"mode": "off", "time_s": [0.0, 1.0, 2.0]}, "time_s"),
        ({"mode": "off", "time_s": [True, False]}, "time_s"),
        ({"mode": "stuck", "stuck_for_s": "long"}, "stuck_for_s"),
        ({"mode": "stuck", "stuck_for_s": [[0.1]]}, "stuck_for_s"),
        ({"mode": "degraded", "thrust_factor": [0.5, 1.5]}, "thrust_factor"),
        ({"mode": "degraded", "thrust_factor": {"lo": 0.5}}, "thrust_factor"),
        ({"mode": "off", "probability": "often"}, "probability"),
        ({"mode": "off", "when": 3}, "when"),
    ],
)
def test_bad_fault_tables_name_the_key_and_value(table, key):
    with pytest.raises(InputError, match=key) as err:
        fault_spec(table, WHERE, longest_s=20.0, n_jets=16)
    assert "[dispersions.fault]" in str(err.value) and "\n" not in str(err.value)


@pytest.mark.parametrize(
    "name, table, key",
    [
        ("sensor", {"att_noise_deg": "high"}, "att_noise_deg"),
        ("sensor", {"att_noise_deg": [[0.1]]}, "att_noise_deg"),
        ("sensor", {"att_noise_deg": [0.1, 0.2]}, "att_noise_deg"),
        ("sensor", {"rate_noise_deg_s": {"x": 1}}, "rate_noise_deg_s"),
        ("timing", {"open_delay_s": [0.01]}, "open_delay_s"),
        ("timing", {"open_delay_s": "fast"}, "open_delay_s"),
    ],
)
def test_bad_sensor_and_timing_tables_name_the_key(name, table, key):
    with pytest.raises(InputError, match=key):
        parse_effects({name: table}, source="spec.toml", cycle_s=0.04, longest_s=20.0, n_jets=16)
