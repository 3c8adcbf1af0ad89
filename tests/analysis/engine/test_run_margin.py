"""The runs table's ``margin`` (rcsim.analysis.engine.run_margin): a run fails exactly when its
margin is not >= 0, on a flown campaign and at the thresholds' edges.

The identity is the contract a rare-event estimation rests on (its failure is ``margin < 0``,
``docs/rare_events.md``): every comparison here is exact (no tolerance), because the margin's
sign is computed from the very values the criterion compares.
"""

import numpy as np
import pytest

from rcsim.analysis.engine.campaign.chunk import Chunk, simulate_chunk
from rcsim.analysis.engine.campaign.spec import parse_dict
from rcsim.analysis.engine.run_margin import JUST_BELOW_ZERO, criterion_terms, run_margin


def _rate_only(rates, thr=1.0):
    return run_margin(
        criterion_terms(final_rate_err_rad_s=np.asarray(rates, float), rate_threshold_rad_s=thr),
        np.zeros(len(rates), bool),
    )


def test_rate_term_fails_at_the_threshold_itself():
    """The rate criterion is ``not |error| < thr``: an error equal to thr fails, so its margin
    is the float just below 0; half the threshold leaves (1 - 0.5) / 1 = 0.5 exactly."""
    m = _rate_only([[0.5, -0.25, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.5]])
    assert m[0] == 0.5
    assert m[1] == JUST_BELOW_ZERO and m[1] < 0
    assert m[2] == -0.5


def test_attitude_term_passes_at_its_threshold_and_nan_fails():
    """Attitude fails only beyond its threshold (``not error <= thr``): a margin of exactly 0
    stays 0 (passes); a NaN error and a failed simulation give NaN (not >= 0: failed)."""
    terms = criterion_terms(
        final_rate_err_rad_s=np.zeros((3, 3)),
        rate_threshold_rad_s=1.0,
        final_att_err_deg=np.array([2.0, 3.0, np.nan]),
        attitude_threshold_deg=2.0,
    )
    m = run_margin(terms, np.array([False, False, False]))
    assert m[0] == 0.0 and m[1] == -0.5 and np.isnan(m[2])
    assert np.isnan(run_margin(terms, np.array([True, False, False]))[0])


def test_propellant_exhaustion_is_a_failing_term():
    terms = criterion_terms(
        final_rate_err_rad_s=np.zeros((2, 3)),
        rate_threshold_rad_s=1.0,
        propellant_exhausted_s=np.array([np.nan, 4.2]),
    )
    assert list(run_margin(terms, np.zeros(2, bool))) == [1.0, -1.0]


@pytest.mark.parametrize("attitude, propellant", [(None, None), (0.5, None), (None, 0.0064)])
def test_campaign_runs_fail_exactly_when_margin_is_negative(attitude, propellant):
    """A flown chunk of 40 runs of case 13 (Table 5 x 3, 3 s): thresholds set so that some
    runs fail and some pass (checked, else the identity would hold vacuously); then
    ``failed == ~(margin >= 0)`` for every run, and the margin recomputed from the row's
    deg/s columns (rounding: rad -> deg and back, a few ulps) agrees to 1e-9."""
    failure = {"rate_error_deg_s": 0.05}
    if attitude is not None:
        failure["attitude_error_deg"] = attitude
    if propellant is not None:  # a [failure] budget (issue 28): its term joins the margin
        failure["max_propellant_kg"] = propellant
    spec = parse_dict(
        {
            "seed": 3,
            "runs_per_case": 40,
            "scenario": {"kind": "rate-cases", "cases": [13], "duration_s": 3.0},
            "controller": {"name": "lookup"},
            "dispersions": {"scale": 3.0},
            "failure": failure,
            "output": {"histories": "none", "plots": False},
        }
    )
    rows = simulate_chunk(spec, Chunk(0, 40)).runs
    failed = rows["failed"].to_numpy(bool)
    margin = rows["margin"].to_numpy(float)
    assert 0 < failed.sum() < failed.size, "thresholds must split the runs"
    np.testing.assert_array_equal(failed, ~(margin >= 0))
    worst = rows[[f"final_rate_err_{a}_deg_s" for a in ("roll", "pitch", "yaw")]].abs().max(axis=1)
    expected = (0.05 - worst) / 0.05
    if attitude is not None:
        expected = np.minimum(expected, (attitude - rows["final_att_err_deg"]) / attitude)
    if propellant is not None:
        by_budget = rows["failed_by"].str.contains("max_propellant_kg")
        assert 0 < by_budget.sum() < len(rows), "the budget must split the runs"
        expected = np.minimum(expected, (propellant - rows["propellant_kg"]) / propellant)
    np.testing.assert_allclose(margin, expected, rtol=0, atol=1e-9)
