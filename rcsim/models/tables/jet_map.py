"""The jet map (paper Table 2): :func:`load_jet_map`."""

from __future__ import annotations

import numpy as np

from rcsim.models.tables.constants import AXES, N_JETS, SIGN_COLUMNS
from rcsim.models.tables.schema import (
    PathLike,
    cell_error,
    check_columns,
    index_column,
    number,
    read_raw,
)


def load_jet_map(path: PathLike | None = None) -> np.ndarray:
    """Load the jet map (paper Table 2): torque sign of each jet about roll, pitch, yaw.

    Parameters
    ----------
    path : str or os.PathLike, optional
        A CSV with columns ``jet, roll_sign, pitch_sign, yaw_sign``; jets 1..16 once each;
        signs in {-1, 0, 1}.  Default: the packaged ``table2_jet_map.csv``.

    Returns
    -------
    numpy.ndarray of int, shape (16, 3)
        Row ``j - 1`` is jet ``j``; columns roll, pitch, yaw.  All-zero rows are jets unused for
        rotation (the paper's translation jets 5-8).

    Raises
    ------
    rcsim.models.errors.InputError
        Missing/unknown column, a jet number missing/duplicated/outside 1..16, a sign not in
        {-1, 0, 1}, a jet with torque on two axes (paper section IV: "the current logic does
        not allow for a single thruster to be used for multiple axes"), or an axis direction
        no jet provides (some rate cases could then never be commanded).
    """
    raw = read_raw(path, "table2_jet_map.csv")
    check_columns(raw, ("jet", *SIGN_COLUMNS))
    jets = index_column(raw, "jet", N_JETS, "jet")
    jmap = np.zeros((N_JETS, 3), dtype=int)
    for i, jet in enumerate(jets):
        for a, col in enumerate(SIGN_COLUMNS):
            v = number(raw, i, col, jet=jet)
            if v not in (-1.0, 0.0, 1.0):
                raise cell_error(
                    raw.file,
                    "sign must be -1, 0 or 1",
                    row=i + 1,
                    jet=jet,
                    column=col,
                    value=raw.cell(i, col),
                )
            jmap[jet - 1, a] = int(v)
        if np.count_nonzero(jmap[jet - 1]) > 1:
            col = SIGN_COLUMNS[int(np.flatnonzero(jmap[jet - 1])[1])]
            raise cell_error(
                raw.file,
                "jet gives torque on more than one axis",
                row=i + 1,
                jet=jet,
                column=col,
                value=raw.cell(i, col),
            )
    for a, col in enumerate(SIGN_COLUMNS):
        for s in (-1, 1):
            if not np.any(jmap[:, a] == s):
                # No single cell is wrong: name the column and the value that never appears.
                raise cell_error(
                    raw.file,
                    f"no jet gives {s:+d} {AXES[a]} torque (every axis needs a jet of each sign)",
                    column=col,
                    value=s,
                )
    return jmap
