"""Resuming a rare-event estimation from its per-level state file
(rcsim.analysis.engine.rare.state).

Oracle: the uninterrupted estimation with the same seed.  A killed estimation resumed from its
file must give the same answer bit for bit, without evaluating again the levels it kept.
"""

import numpy as np
import pytest

from rcsim.analysis.engine.rare import SubsetConfig, limit_states, subset_simulation
from rcsim.analysis.engine.rare.state import SubsetState
from rcsim.models.errors import InputError

LIMIT = limit_states.series(10, 1e-5)
CONFIG = SubsetConfig(n_per_level=500)


class Killed(Exception):
    """Stands for the process dying after a level's state was written."""


def _counting(limit):
    calls = {"points": 0}

    def g(u, ids):
        calls["points"] += u.shape[0]
        return limit(u, ids)

    return g, calls


def _same(a, b):
    assert a.probability == b.probability and a.cov == b.cov and a.interval == b.interval
    assert a.n_evaluations == b.n_evaluations and a.levels == b.levels
    assert np.array_equal(a.failures_u, b.failures_u)
    assert np.array_equal(a.failures_id, b.failures_id)
    assert a.closest_failure.eval_id == b.closest_failure.eval_id


@pytest.mark.parametrize("kill_after", [0, 2])
def test_a_killed_estimation_resumes_at_its_last_level_with_the_same_answer(tmp_path, kill_after):
    whole = subset_simulation(LIMIT, 10, CONFIG, seed=21)
    assert len(whole.levels) > kill_after + 2  # the kill leaves levels to do

    path = tmp_path / "rare_state.npz"

    def kill(record):
        if record.level == kill_after:
            raise Killed

    g, calls = _counting(LIMIT)
    with pytest.raises(Killed):
        subset_simulation(g, 10, CONFIG, seed=21, state_path=path, progress=kill)
    done = calls["points"]
    assert done == 500 + 450 * kill_after

    g, calls = _counting(LIMIT)
    seen = []
    resumed = subset_simulation(g, 10, CONFIG, seed=21, state_path=path, progress=seen.append)
    _same(resumed, whole)
    assert calls["points"] == whole.n_evaluations - done  # the kept levels are not flown again
    assert [r.level for r in seen] == list(range(kill_after + 1, len(whole.levels)))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rare_state.npz"]  # no temp file


def test_a_finished_state_returns_its_result_without_evaluating(tmp_path):
    path = tmp_path / "s.npz"
    first = subset_simulation(LIMIT, 10, CONFIG, seed=3, state_path=path)
    g, calls = _counting(LIMIT)
    again = subset_simulation(g, 10, CONFIG, seed=3, state_path=path)
    _same(again, first)
    assert calls["points"] == 0


def test_a_state_round_trips_exactly(tmp_path):
    path = tmp_path / "s.npz"
    seen = []
    subset_simulation(LIMIT, 10, CONFIG, seed=4, state_path=path, progress=seen.append)
    state = SubsetState.load(path, _problem(path))
    state.save(tmp_path / "t.npz")
    back = SubsetState.load(tmp_path / "t.npz", state.problem)
    assert back.levels == state.levels == seen
    for name in ("u", "margins", "ids", "fail_u", "fail_margins", "fail_ids"):
        assert np.array_equal(getattr(back, name), getattr(state, name))
        assert getattr(back, name).dtype == getattr(state, name).dtype
    assert back.scale == state.scale and back.n_evaluations == state.n_evaluations


def _problem(path):
    import json

    with np.load(path, allow_pickle=False) as data:
        return json.loads(str(data["meta"]))["problem"]


@pytest.mark.parametrize(
    "change, key",
    [
        ({"config": SubsetConfig(n_per_level=1000)}, "config"),
        ({"seed": 22}, "seed_entropy"),
        ({"label": "another"}, "label"),
    ],
)
def test_a_state_of_another_estimation_is_refused_naming_what_differs(tmp_path, change, key):
    path = tmp_path / "s.npz"
    subset_simulation(LIMIT, 10, CONFIG, seed=21, state_path=path, label="series")
    kwargs = {"config": CONFIG, "seed": 21, "label": "series", **change}
    config = kwargs.pop("config")
    with pytest.raises(InputError, match=rf"belongs to another estimation \({key}:"):
        subset_simulation(LIMIT, 10, config, state_path=path, **kwargs)


def test_a_state_begun_from_other_level_zero_points_is_refused(tmp_path):
    path = tmp_path / "s.npz"
    u0 = np.random.default_rng(np.random.SeedSequence(5)).standard_normal((500, 10))
    subset_simulation(LIMIT, 10, CONFIG, seed=21, state_path=path, u0=u0)
    with pytest.raises(InputError, match=r"another estimation \(u0:"):
        subset_simulation(LIMIT, 10, CONFIG, seed=21, state_path=path, u0=u0[::-1])


def test_a_file_that_is_not_a_state_is_refused(tmp_path):
    path = tmp_path / "s.npz"
    path.write_text("not a state")
    with pytest.raises(InputError, match="not a rare-event state file"):
        subset_simulation(LIMIT, 10, CONFIG, seed=1, state_path=path)
