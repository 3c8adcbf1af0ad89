"""Case-by-case comparison of two lookup tables (e.g. a generated one against the paper's).

Imports ``models``, ``rcsim.spacecraft.vehicle`` and ``rcsim.lookup.pattern_recognition`` only.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from rcsim.lookup.pattern_recognition import learn_jets
from rcsim.models.tables import LookupTable
from rcsim.spacecraft.vehicle.model import AXES


def axis_times(table: LookupTable) -> tuple[np.ndarray, np.ndarray]:
    """Per case and axis, the firing time and which jets fire, learned from the table alone.

    Returns
    -------
    time_s : ndarray, (26, 3)
        Longest firing time on each axis (pairs fire equally) [s], 0 if none.
    jets : ndarray of bool, (26, 16)
        Jets that fire.
    """
    axis, _, _ = learn_jets(table)
    ft = np.asarray(table.firing_time_s)
    time_s = np.stack([np.where(axis[None, :] == a, ft, 0.0).max(axis=1) for a in range(3)], 1)
    return time_s, ft > 0


def compare_tables(generated: LookupTable, paper: LookupTable, cycle_s: float) -> pd.DataFrame:
    """Case-by-case comparison of two lookup tables (e.g. generated vs paper Table 6).

    Returns
    -------
    pandas.DataFrame
        One row per case: ``case``, ``pattern`` (e.g. ``"(-,+,0)"``), ``jets_agree`` (same
        firing jets), per axis ``<axis>_gen_s``, ``<axis>_paper_s`` and ``<axis>_diff_cycles``
        (generated minus paper, in control cycles), and ``within_one_cycle``.
    """
    if not np.array_equal(np.sign(generated.rate_cmd), np.sign(paper.rate_cmd)):
        raise ValueError("tables have different case patterns; cannot compare case by case")
    g_t, g_j = axis_times(generated)
    p_t, p_j = axis_times(paper)
    signs = np.sign(np.asarray(generated.rate_cmd)).astype(int)
    sym = {-1: "-", 0: "0", 1: "+"}
    cols = {
        "case": np.asarray(generated.case),
        "pattern": ["(" + ",".join(sym[s] for s in row) + ")" for row in signs],
        "jets_agree": np.all(g_j == p_j, axis=1),
    }
    diff = np.rint((g_t - p_t) / cycle_s).astype(int)
    for a, ax in enumerate(AXES):
        cols[f"{ax}_gen_s"] = g_t[:, a].round(6)
        cols[f"{ax}_paper_s"] = p_t[:, a].round(6)
        cols[f"{ax}_diff_cycles"] = diff[:, a]
    cols["within_one_cycle"] = np.all(np.abs(diff) <= 1, axis=1)
    return pd.DataFrame(cols)
