"""Edits of a lookup table in whole control cycles: which cells, by how much.

Automated refinement (Gambone sec. III: "updating the lookup table based on Monte Carlo results
can be automated") changes a case's firing time on one axis at a time: every jet of that axis
that fires in the case (a jet pair, Table 2) moves by the same whole number of control cycles,
so the pair stays balanced (no net force) and the time stays a whole number of cycles, as the
table loader requires.  This module is the pure arithmetic of those edits; flying and scoring
the candidates is :mod:`rcsim.analysis.apps.refinement`.

Imports ``models`` and the controller's jet learning only; never ``analysis``.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from rcsim.lookup.pattern_recognition import learn_jets
from rcsim.models.tables import AXES, LookupTable

#: Tolerance for "a whole number of cycles" [cycles]; table times are read from decimal text.
_CYCLE_ATOL = 1e-6


def jet_axes(table: LookupTable) -> np.ndarray:
    """Axis each jet serves (0 roll, 1 pitch, 2 yaw; -1 unused), learned from the table alone.

    Returns
    -------
    ndarray of int, (16,)
    """
    return learn_jets(table)[0]


def axis_cycles(firing_time_s: np.ndarray, jet_axis: np.ndarray, cycle_s: float) -> np.ndarray:
    """Firing time of each case's jets per axis, in control cycles (0: the axis does not fire).

    Parameters
    ----------
    firing_time_s : ndarray, (..., 26, 16)
        One table's times or a stack of tables [s].
    jet_axis : ndarray of int, (16,)
        :func:`jet_axes`.

    Returns
    -------
    ndarray of int, (..., 26, 3)
        The longest firing time among the axis's jets in that case, in cycles.
    """
    times = np.asarray(firing_time_s, float)
    out = np.zeros(times.shape[:-1] + (len(AXES),))
    for a in range(len(AXES)):  # three axes, not runs
        jets = np.flatnonzero(jet_axis == a)
        if jets.size:
            out[..., a] = times[..., jets].max(axis=-1)
    cycles = out / cycle_s
    if not np.allclose(cycles, np.round(cycles), atol=_CYCLE_ATOL, rtol=0.0):
        raise ValueError(f"firing times are not whole {cycle_s} s control cycles")
    return np.round(cycles).astype(int)


def shift_axes(
    firing_time_s: np.ndarray,
    jet_axis: np.ndarray,
    shift_cycles: np.ndarray,
    cycle_s: float,
) -> np.ndarray:
    """Move every firing jet of an axis in a case by a whole number of cycles.

    Parameters
    ----------
    firing_time_s : ndarray, (26, 16)
        The table's times [s].
    jet_axis : ndarray of int, (16,)
        :func:`jet_axes`.
    shift_cycles : ndarray of int, (26, 3)
        Cycles to add per case and axis (negative: shorter).  Only jets that already fire in
        the case move: an edit never starts or stops a jet (the jet pattern is the table's
        design, Gambone sec. II).

    Returns
    -------
    ndarray, (26, 16)
        New times [s].

    Raises
    ------
    ValueError
        A shift on an axis that does not fire in the case, or one that would leave a firing
        jet with less than one control cycle.
    """
    times = np.array(firing_time_s, float)
    shift = np.asarray(shift_cycles)
    if shift.shape != times.shape[:-1] + (len(AXES),):
        raise ValueError(
            f"shift_cycles must have shape {times.shape[:-1] + (len(AXES),)}, got {shift.shape}"
        )
    per_jet = np.where(jet_axis >= 0, shift[:, np.maximum(jet_axis, 0)], 0)  # (26, 16)
    firing = times > 0
    cycles_now = axis_cycles(times, jet_axis, cycle_s)
    bad = (shift != 0) & (cycles_now == 0)
    if bad.any():
        c, a = np.argwhere(bad)[0]
        raise ValueError(f"case row {c}: the {AXES[a]} axis does not fire; nothing to shift")
    new = np.where(firing, times + per_jet * cycle_s, 0.0)
    if np.any(firing & (new < cycle_s * (1 - 1e-9))):
        c, j = np.argwhere(firing & (new < cycle_s * (1 - 1e-9)))[0]
        raise ValueError(
            f"case row {c}, jet_{j + 1:02d}: a shift of {per_jet[c, j]} cycles "
            "leaves less than one control cycle"
        )
    # Snap to whole cycles: repeated shifts must not accumulate decimal error.
    return np.where(firing, np.round(new / cycle_s) * cycle_s, 0.0)


def with_times(table: LookupTable, firing_time_s: np.ndarray, source: str) -> LookupTable:
    """``table`` with new firing times (same cases and rate commands)."""
    return replace(table, firing_time_s=np.asarray(firing_time_s, float), source=source)
