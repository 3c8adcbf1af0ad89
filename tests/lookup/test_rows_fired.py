"""Which table rows each run fires (``LookupController.record_rows``), recorded for the
refinement: a correction firing picks its row by the sign pattern of the rate error, so a row
flies in other cases' runs too.

Oracles: recording only reads what the cycle decided, so a flight with it is the flight
without it, byte for byte; the compiled cycle and the numpy form record the same rows (both
return the row and the axes that started a new firing); a run from rest first sees the
commanded rate as its error, whose sign pattern is its own case's row (Table 3), so every run
fires its own row; a row that fires twice as long as it should overshoots, and the correction
fires the row of the opposite sign.
"""

from __future__ import annotations

import numpy as np
import pytest

from rcsim.analysis.apps.refinement.parameters import refinement_spec
from rcsim.analysis.engine.flight import fly_batch
from rcsim.lookup import step_kernel
from rcsim.lookup.pattern_recognition import LookupController, LookupParams
from rcsim.models.tables import load_lookup_table
from rcsim.spacecraft.dispersions import draw_runs

RUNS = 4  # per case; 26 x 4 runs of 8 s under Table 5 dispersions


def _table():
    """Table 6 with case 14's (0, 0, +) yaw firing twice as long: its runs overshoot to about
    twice the commanded yaw rate, so their correction fires case 13's (0, 0, -) row."""
    from dataclasses import replace

    table = load_lookup_table(which="table6")
    times = np.array(table.firing_time_s, float)
    times[13] *= 2.0
    return replace(table, firing_time_s=times)


def _fly(record: bool):
    spec = refinement_spec(runs_per_case=RUNS, seed=5, duration_s=8.0)
    vehicle = spec.vehicle
    ids = np.arange(26 * RUNS)
    params = draw_runs(vehicle.nominal(1), spec.sigmas, spec.seed, ids).params
    controller = LookupController(_table(), LookupParams.from_profile(vehicle.control))
    if record:
        controller.record_rows()
    history = fly_batch([spec.cases[i // RUNS] for i in ids], params, controller, vehicle=vehicle)
    return history, controller.rows_fired


def test_recording_leaves_the_flight_unchanged_and_every_run_fires_its_own_row():
    plain, none = _fly(False)
    recorded, rows = _fly(True)
    assert none is None
    for name in ("q_BN", "omega_B", "on_time_s", "failed"):
        a, b = np.asarray(getattr(plain, name)), np.asarray(getattr(recorded, name))
        assert a.tobytes() == b.tobytes(), name
    assert rows.shape == (26 * RUNS, 26)
    own = np.arange(26 * RUNS) // RUNS
    assert rows[np.arange(26 * RUNS), own].all()
    # Case 14's overshoot is corrected with case 13's row, in every one of its runs.
    assert rows[own == 13, 12].all()
    assert not rows[own == 12, 13].any()  # case 13's own firing is Table 6's


@pytest.mark.skipif(step_kernel._step_kernel is None, reason="the optional extension was not built")
def test_the_compiled_cycle_and_the_numpy_form_record_the_same_rows(monkeypatch):
    _, compiled = _fly(True)
    monkeypatch.setenv("RCSIM_NUMPY_CONTROLLER", "1")
    _, reference = _fly(True)
    np.testing.assert_array_equal(compiled, reference)
