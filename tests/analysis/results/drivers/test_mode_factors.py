"""The modes' frequency ratio (factors.mode_factors): its definition by hand, the recorded mode
columns as driver inputs, and a planted resonance found by ``analyze``."""

import numpy as np
import pandas as pd
import pytest

from rcsim.analysis.engine import runs_table
from rcsim.analysis.results.drivers.factors import firing_frequency_hz, mode_factors
from rcsim.analysis.results.drivers.inputs import load_runs
from rcsim.analysis.results.drivers.pipeline import Settings, analyze
from rcsim.analysis.results.drivers.report_sections import _physics_text


def test_ratio_by_hand():
    """Run 0: 30 pulses at 90 a minute flew T = 20 s; its busiest axis fired 10 events, so
    f_fire = 0.5 Hz and a 0.41 Hz mode has the ratio 0.82.  Run 1: 12 events in 60 s (0.2 Hz):
    0.42 / 0.2 = 2.1.  Run 2 never fired: no firing frequency, placed at the largest + 1."""
    runs = pd.DataFrame(
        {
            "firings_roll": [10.0, 3.0, 0.0],
            "firings_pitch": [4.0, 12.0, 0.0],
            "firings_yaw": [2.0, 0.0, 0.0],
            "pulses": [30.0, 40.0, 0.0],
            "pulses_per_min": [90.0, 40.0, 0.0],
            "mode_wing_coupled_freq_hz": [0.41, 0.42, 0.43],
        }
    )
    np.testing.assert_allclose(firing_frequency_hz(runs)[:2], [0.5, 0.2], rtol=1e-15)
    factors, unplaced = mode_factors(runs)
    assert list(factors.columns) == ["mode_wing_freq_ratio"]
    np.testing.assert_allclose(factors["mode_wing_freq_ratio"], [0.82, 2.1, 3.1], rtol=1e-14)
    assert unplaced == 1


def _resonant_runs(n: int = 600, seed: int = 5) -> pd.DataFrame:
    """Recorded vehicle inputs and one dispersed wing (noise), each run's firing frequency
    spread widely (lognormal, not an input) and failures planted on the ratio of the wing's
    coupled frequency to it: a run whose limit cycle is within 15 % of the wing fails."""
    rng = np.random.default_rng(seed)
    frame = pd.DataFrame({c: rng.normal(1.0, 0.1, n) for c in runs_table.input_names(16)})
    frame.insert(0, "run_id", np.arange(n))
    frame["case"] = "rate-13"
    clamped = rng.normal(0.4, 0.01, n)
    frame["mode_wing_freq_hz"] = clamped
    frame["mode_wing_coupled_freq_hz"] = clamped * 1.03
    frame["mode_wing_damping"] = rng.normal(0.005, 0.001, n)
    frame["mode_wing_inertia_kg_m2"] = 91.8
    f_fire = 0.41 * np.exp(rng.normal(0.0, 0.5, n))
    duration = 20.0
    events = f_fire * duration
    frame["firings_roll"] = events
    frame["firings_pitch"] = 0.5 * events
    frame["firings_yaw"] = 0.25 * events
    frame["pulses"] = 2.0 * events
    frame["pulses_per_min"] = frame["pulses"] / (duration / 60.0)
    ratio = frame["mode_wing_coupled_freq_hz"] / f_fire
    frame["failed"] = (np.abs(ratio - 1.0) < 0.15).to_numpy()
    return frame


def test_mode_columns_are_inputs_and_the_ratio_is_derived():
    """By default the recorded mode columns are inputs (the undispersed inertia left out as
    constant) and mode_wing_freq_ratio is a derived factor, equal to the hand formula."""
    frame = _resonant_runs()
    runset = load_runs(frame)
    assert {"mode_wing_freq_hz", "mode_wing_coupled_freq_hz", "mode_wing_damping"} <= set(
        runset.raw_inputs
    )
    assert "mode_wing_inertia_kg_m2" not in runset.X.columns
    assert runset.derived_inputs == ["mode_wing_freq_ratio"]
    by_hand = frame["mode_wing_coupled_freq_hz"] / (frame["firings_roll"] / 20.0)
    np.testing.assert_allclose(runset.X["mode_wing_freq_ratio"], by_hand, rtol=1e-12)


def test_a_planted_resonance_is_flagged():
    """Failures planted on the ratio alone (two-sided: near 1): analyze ranks
    mode_wing_freq_ratio first and significant, and the report explains it."""
    frame = _resonant_runs()
    assert 0.05 < frame["failed"].mean() < 0.5
    res = analyze(load_runs(frame), Settings(n_permutations=99))
    top = res.drivers.sort_values("rank").iloc[0]
    assert top["factor"] == "mode_wing_freq_ratio" and bool(top["significant"])
    text = " ".join(_physics_text(res))
    assert "mode_<name>_freq_ratio" in text and "busiest axis" in text
    assert "authority_" not in text  # no vehicle: no jet-group factor to explain


@pytest.mark.parametrize("missing", ["pulses", "firings_yaw"])
def test_no_ratio_without_the_firing_columns(missing):
    frame = _resonant_runs(n=50).drop(columns=[missing])
    factors, _ = mode_factors(frame)
    assert factors.empty
