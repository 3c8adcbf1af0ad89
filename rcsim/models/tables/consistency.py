"""The cross-table check: a lookup table's firing times against its rate commands (Table 3)
and the jet map (Table 2), plus the physical range of a firing time."""

from __future__ import annotations

import math

import numpy as np

from rcsim.models.errors import InputError
from rcsim.models.tables.constants import AXES, MAX_FIRING_TIME_S, PAPER_CYCLE_S, TIME_ATOL_S
from rcsim.models.tables.schema import cell_error


def check_consistency(
    case: np.ndarray,
    rate_cmd: np.ndarray,
    firing_time_s: np.ndarray,
    jet_map: np.ndarray,
    *,
    file: str = "<lookup table>",
    rows: np.ndarray | None = None,
    cycle_s: float | None = PAPER_CYCLE_S,
    max_firing_time_s: float | None = MAX_FIRING_TIME_S,
    columns=None,
) -> None:
    """Check a lookup table's firing times against its rate commands and the jet map.

    Rules (paper section II: the thrusters fire in their "designed firing direction", Table 2;
    damping "requires equal firing times with the opposing thrusters"; control rate 40 ms):

    1. firing times are finite, >= 0 and (if ``max_firing_time_s``) at most
       ``max_firing_time_s`` (default ``MAX_FIRING_TIME_S`` = 5 s; why, see
       :mod:`~rcsim.models.tables.constants`);
    2. (if ``cycle_s``) every firing time is a whole number of control cycles, within
       ``TIME_ATOL_S``;
    3. a jet whose jet-map row is all zero (unused, e.g. translation jets) never fires;
    4. on each axis, the jets that fire are exactly the jets whose jet-map sign equals the
       sign of that axis's rate command -- so an axis with zero rate has no firing jet;
    5. all jets sharing an axis and sign (a pair) fire equally long, within ``TIME_ATOL_S``.

    Parameters
    ----------
    case : array_like of int, shape (n,)
        Case numbers, for messages.
    rate_cmd : array_like of float, shape (n, 3)
        Rate command per case [roll, pitch, yaw], rad/s.  Only the signs are used.
    firing_time_s : array_like of float, shape (n, 16)
        Firing time of jets 1..16 per case, s.
    jet_map : array_like of int, shape (16, 3)
        Jet map (paper Table 2): sign of the torque each jet gives about roll, pitch, yaw.
    file : str
        File name to put in messages.
    rows : array_like of int, shape (n,), optional
        1-based data row in ``file`` of each case (default ``1..n``).
    cycle_s : float or None
        Control cycle, s; None skips rule 2.
    max_firing_time_s : float or None
        Longest allowed firing time, s; None skips the upper bound of rule 1.
    columns : sequence of str, optional
        Column names for messages (default ``jet_01 ...``); a channel table's are its
        channels' (:mod:`rcsim.models.tables.channels`), whose "jet map" is the channel map.

    Raises
    ------
    rcsim.models.errors.InputError
        At the first broken rule, naming file, row, case, column (``jet_NN``) and value.
    """
    case = np.asarray(case, dtype=int)
    rate = np.asarray(rate_cmd, dtype=float)
    times = np.asarray(firing_time_s, dtype=float)
    jmap = np.asarray(jet_map, dtype=int)
    n = len(case)
    if rate.shape != (n, 3) or times.shape != (n, jmap.shape[0]) or jmap.shape[1:] != (3,):
        raise InputError(
            f"{file}: wrong shape: case {case.shape}, rate_cmd {rate.shape}, firing_time_s "
            f"{times.shape}, jet_map {jmap.shape}; need (n,), (n, 3), (n, jets), (jets, 3)"
        )
    for name, value in (("cycle_s", cycle_s), ("max_firing_time_s", max_firing_time_s)):
        if value is not None and not (math.isfinite(value) and value > 0):
            raise InputError(f"{name}={value!r}: must be a finite time > 0 s, or None")
    rows = np.arange(1, n + 1) if rows is None else np.asarray(rows, dtype=int)
    names = [f"jet_{j + 1:02d}" for j in range(jmap.shape[0])] if columns is None else columns
    # How a column is called in a sentence: "jet 3", or "channel plus_yaw".
    what = (
        [f"jet {j + 1}" for j in range(jmap.shape[0])]
        if columns is None
        else [f"channel {c}" for c in columns]
    )
    rate_deg = np.rad2deg(rate)
    rate_sign = np.sign(rate).astype(int)
    for k in range(n):
        loc = dict(row=int(rows[k]), case=int(case[k]))
        for j in range(jmap.shape[0]):
            col = names[j]
            t = float(times[k, j])
            if not math.isfinite(t):
                raise cell_error(file, "NaN/infinite firing time", column=col, value=t, **loc)
            if t < 0:
                raise cell_error(
                    file, "wrong sign: firing time must be >= 0", column=col, value=t, **loc
                )
            if max_firing_time_s is not None and t > max_firing_time_s:
                raise cell_error(
                    file,
                    f"firing time outside the physical range 0..{max_firing_time_s:g} s: a "
                    "table firing is one feedback pulse (the paper's longest is 0.52 s), this "
                    f"one holds the jet on, open loop, for {t / (cycle_s or PAPER_CYCLE_S):.4g} "
                    "control cycles (a time in ms under an s header?)",
                    column=col,
                    value=t,
                    **loc,
                )
            if cycle_s is not None:
                cycles = t / cycle_s
                if abs(cycles - round(cycles)) * cycle_s > TIME_ATOL_S:
                    raise cell_error(
                        file,
                        f"firing time is not a whole number of {cycle_s * 1e3:g} ms control "
                        f"cycles ({cycles:.4g} cycles)",
                        column=col,
                        value=t,
                        **loc,
                    )
            axes = np.flatnonzero(jmap[j])
            if len(axes) == 0:
                if t > 0:
                    raise cell_error(
                        file,
                        f"{what[j]} is unused in the jet map (no torque) but fires"
                        if columns is None
                        else f"{what[j]} fires, but its recipe serves no jet (no combination "
                        "of the jets left turns the vehicle that way)",
                        column=col,
                        value=t,
                        **loc,
                    )
                continue
            for a in axes:
                s = int(jmap[j, a])
                should_fire = rate_sign[k, a] == s
                jet = f"{what[j]} ({AXES[a]} {s:+d})"
                cmd = f"the {AXES[a]} rate command is {rate_deg[k, a]:+.4g} deg/s"
                if should_fire and t == 0:
                    raise cell_error(
                        file, f"{jet} does not fire although {cmd}", column=col, value=t, **loc
                    )
                if not should_fire and t > 0:
                    raise cell_error(
                        file, f"{jet} fires although {cmd}", column=col, value=t, **loc
                    )
        # Rule 5: jets with the same jet-map row (same axis and sign) are a pair.
        groups: dict[tuple, list[int]] = {}
        for j in range(jmap.shape[0]):
            if jmap[j].any():
                groups.setdefault(tuple(jmap[j]), []).append(j)
        for members in groups.values():
            first = members[0]
            for j in members[1:]:
                if abs(times[k, j] - times[k, first]) > TIME_ATOL_S:
                    raise cell_error(
                        file,
                        f"paired jets fire unequal times: {what[j]} vs {what[first]} "
                        f"({times[k, first]:g} s); a pair must fire equally long",
                        column=names[j],
                        value=float(times[k, j]),
                        **loc,
                    )
