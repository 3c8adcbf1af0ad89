"""How the refinement scores candidate tables from their runs (Gambone sec. III: "measuring the
number of firings and the final rate error").

A run *fails* as the campaign says (``failed``); it *repeats* when some axis needed more than
one firing event to reach its commanded rate (``firings_to_rate_<axis> > 1``).  A candidate is
better when fewer of its runs fail, then fewer repeat.  Pure functions of outcome frames: the
flying is :mod:`rcsim.analysis.apps.refinement.evaluate`'s.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from rcsim.models.tables import AXES

#: The outcome columns :func:`trial_frame` reads (a campaign's ``runs.parquet`` has ~100 more:
#: a caller scoring a campaign need read only these).
SCORED_COLUMNS = (
    "failed",
    *(f"firings_to_rate_{a}" for a in AXES),
    *(f"final_rate_err_{a}_deg_s" for a in AXES),
    "propellant_kg",
)


def trial_frame(trial, case, k, outcome: pd.DataFrame) -> pd.DataFrame:
    """The per-run scoring frame of candidate ``trial`` runs from their campaign outcome columns
    (row-aligned): ``trial, case_index, k, failed, repeated``, ``firings_to_rate_<axis>``,
    ``final_rate_err_<axis>_deg_s`` and ``propellant_kg`` (the refinement's second objective,
    :mod:`rcsim.analysis.apps.refinement.propellant`); ``rows_fired`` when the outcomes have it
    (the table rows each run fired, a bitmask)."""
    to_rate = outcome[[f"firings_to_rate_{a}" for a in AXES]].to_numpy(float)
    result = pd.DataFrame(
        {
            "trial": np.asarray(trial),
            "case_index": np.asarray(case),
            "k": np.asarray(k),
            "failed": outcome["failed"].to_numpy(bool),
            # Some axis needed more than one firing event to reach its commanded rate (a run
            # whose simulation failed has NaN counts: failed, but not counted as repeated).
            "repeated": np.nanmax(np.nan_to_num(to_rate, nan=0.0), axis=1) > 1,
        }
    )
    for a, axis in enumerate(AXES):
        result[f"firings_to_rate_{axis}"] = to_rate[:, a]
        result[f"final_rate_err_{axis}_deg_s"] = outcome[f"final_rate_err_{axis}_deg_s"].to_numpy()
    result["propellant_kg"] = outcome["propellant_kg"].to_numpy(float)
    if "rows_fired" in outcome:  # flown by the refinement (a campaign's runs do not record it)
        result["rows_fired"] = outcome["rows_fired"].to_numpy(np.int64)
    return result


def rows_fired_by_trial(runs: pd.DataFrame, n_trials: int) -> np.ndarray:
    """(n_trials,) int64: the table rows any run of each trial fired, as a bitmask (bit ``r``:
    row ``r``; the ``rows_fired`` column of :func:`trial_frame`)."""
    out = np.zeros(n_trials, np.int64)
    np.bitwise_or.at(out, runs["trial"].to_numpy(int), runs["rows_fired"].to_numpy(np.int64))
    return out


def trial_scores(runs: pd.DataFrame, n_trials: int) -> pd.DataFrame:
    """Per trial: ``failed`` and ``repeated`` run counts (the search's two objectives, in that
    order of priority), ``runs``."""
    g = runs.groupby("trial")
    out = pd.DataFrame(
        {"failed": g["failed"].sum(), "repeated": g["repeated"].sum(), "runs": g.size()}
    )
    return out.reindex(np.arange(n_trials), fill_value=0).astype(int)


def offending_runs(runs: pd.DataFrame, threshold_deg_s: float, n_trials: int) -> np.ndarray:
    """(n_trials, 3) int: runs of each trial that failed on, or re-fired on, each axis."""
    out = np.zeros((n_trials, len(AXES)), int)
    for a, axis in enumerate(AXES):
        bad = (runs[f"firings_to_rate_{axis}"].fillna(0) > 1) | ~(
            runs[f"final_rate_err_{axis}_deg_s"].abs() < threshold_deg_s
        )
        counts = runs.loc[bad, "trial"].value_counts()
        out[counts.index.to_numpy(int), a] = counts.to_numpy()
    return out


def score_key(score) -> tuple[int, int]:
    """A trial's objectives in priority order: failed runs, then repeated-firing runs."""
    return int(score["failed"]), int(score["repeated"])


def total(scores: pd.DataFrame) -> tuple[int, int]:
    """:func:`score_key` summed over trials."""
    return int(scores["failed"].sum()), int(scores["repeated"].sum())
