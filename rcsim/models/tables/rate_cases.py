"""The 26 rate-command cases (paper Table 3): :class:`RateCases`, :func:`sign_patterns`,
:func:`load_rate_cases`, and the rate-row checks the lookup-table loader shares."""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from rcsim.models.errors import InputError
from rcsim.models.tables.constants import (
    AXES,
    N_CASES,
    PAPER_TOTAL_RATE_DEG_S,
    RATE_COLUMNS,
    RATE_RTOL,
    RATE_TOTAL_MAX_DEG_S,
    RATE_TOTAL_MIN_DEG_S,
)
from rcsim.models.tables.schema import (
    PathLike,
    cell_error,
    check_columns,
    frozen_array,
    index_column,
    number,
    read_raw,
)


@dataclass(frozen=True, eq=False)
class RateCases:
    """The rate-command cases of the lookup table (paper Table 3), SI.

    Attributes
    ----------
    case : numpy.ndarray of int, shape (26,)
        Case numbers 1..26, ascending.
    rate_cmd : numpy.ndarray of float, shape (26, 3)
        Commanded body rate [roll, pitch, yaw] per case, rad/s.
    """

    case: np.ndarray
    rate_cmd: np.ndarray

    def __post_init__(self) -> None:
        object.__setattr__(self, "case", frozen_array(self.case, int, (N_CASES,), "case"))
        object.__setattr__(
            self, "rate_cmd", frozen_array(self.rate_cmd, float, (N_CASES, 3), "rate_cmd")
        )


def sign_patterns() -> np.ndarray:
    """Every sign pattern of (roll, pitch, yaw) in {-1, 0, +1}^3 except all-zero, roll-major.

    This is the case numbering of the lookup tables: case ``k`` has pattern ``k - 1`` of this
    array (case 1 = (-,-,-), case 2 = (-,-,0), ..., case 26 = (+,+,+)).

    Returns
    -------
    numpy.ndarray of int, shape (26, 3)
        Signs per case, columns roll, pitch, yaw.
    """
    pats = [p for p in itertools.product((-1, 0, 1), repeat=len(AXES)) if any(p)]
    return np.array(pats, dtype=int)


def _fmt_pattern(p) -> str:
    return "(" + ",".join({-1: "-", 0: "0", 1: "+"}[int(s)] for s in p) + ")"


def check_rate_rows(
    file: str,
    rows: np.ndarray,
    case: np.ndarray,
    rate_deg_s: np.ndarray,
    *,
    total_rate_deg_s: float | None,
    roll_major: bool,
    equal_split: bool,
) -> None:
    """Check rate-command rows (deg/s, sorted by case; ``rows`` = 1-based file rows).

    Raises InputError on: an all-zero command; a sign pattern used twice; (``roll_major``) a
    sign pattern other than the case number's roll-major pattern; (``equal_split``) unequal
    magnitudes on the nonzero axes; a total rate outside the physical range
    ``RATE_TOTAL_MIN_DEG_S .. RATE_TOTAL_MAX_DEG_S`` (a unit mistake, see
    :mod:`~rcsim.models.tables.constants`); a total rate off ``total_rate_deg_s`` (or, if
    None, off the common total of all rows) by more than RATE_RTOL relative.
    """
    signs = np.sign(rate_deg_s).astype(int)
    expected = sign_patterns()
    owner: dict[tuple, list[int]] = {}
    for k, p in enumerate(signs):
        owner.setdefault(tuple(p), []).append(int(case[k]))
    for k in range(len(case)):
        c, r, p = int(case[k]), int(rows[k]), signs[k]
        if not p.any():
            raise cell_error(
                file,
                "rate command is zero on every axis",
                row=r,
                case=c,
                column=RATE_COLUMNS[0],
                value=float(rate_deg_s[k, 0]),
            )
        others = [o for o in owner[tuple(p)] if o != c]
        dup = f"; it duplicates case {others[0]}" if others else ""
        # Blame the later of two duplicate rows: the first one is where the pattern belongs.
        earlier = [o for o in others if o < c]
        if roll_major and not np.array_equal(p, expected[c - 1]):
            axis = int(np.flatnonzero(p != expected[c - 1])[0])
            raise cell_error(
                file,
                f"sign pattern {_fmt_pattern(p)} breaks the roll-major case order, which "
                f"gives case {c} the pattern {_fmt_pattern(expected[c - 1])}{dup}",
                row=r,
                case=c,
                column=RATE_COLUMNS[axis],
                value=float(rate_deg_s[k, axis]),
            )
        if earlier:
            axis = int(np.flatnonzero(p)[0])
            raise cell_error(
                file,
                f"sign pattern {_fmt_pattern(p)} used twice (cases {owner[tuple(p)]}); each "
                f"pattern of {{-,0,+}}^3 except all-zero must appear once",
                row=r,
                case=c,
                column=RATE_COLUMNS[axis],
                value=float(rate_deg_s[k, axis]),
            )
    norms = np.linalg.norm(rate_deg_s, axis=1)
    for k in range(len(case)):
        # Physical range first: a table in the wrong unit is self-consistent (one common
        # total), so only the range catches it -- and the message should say "unit", not
        # "this row differs from the others".
        if not RATE_TOTAL_MIN_DEG_S <= norms[k] <= RATE_TOTAL_MAX_DEG_S:
            axis = int(np.flatnonzero(rate_deg_s[k])[0])
            ratio = PAPER_TOTAL_RATE_DEG_S / norms[k]
            hint = (
                f"{ratio:.3g}x smaller than the paper's {PAPER_TOTAL_RATE_DEG_S:g} deg/s; "
                "rad/s written as deg/s is 57.3x smaller"
                if ratio > 1
                else f"{1 / ratio:.3g}x larger than the paper's {PAPER_TOTAL_RATE_DEG_S:g} deg/s"
            )
            raise cell_error(
                file,
                f"total rate {norms[k]:.6g} deg/s is outside the physical range "
                f"{RATE_TOTAL_MIN_DEG_S:g}..{RATE_TOTAL_MAX_DEG_S:g} deg/s (a factor of ten "
                f"around the paper's Table 3 total rate command): {hint}; rates must be in "
                f"deg/s",
                row=int(rows[k]),
                case=int(case[k]),
                column=RATE_COLUMNS[axis],
                value=float(rate_deg_s[k, axis]),
            )
    reference = float(np.median(norms)) if total_rate_deg_s is None else float(total_rate_deg_s)
    what = (
        f"the common total rate {reference:g} deg/s of this table"
        if total_rate_deg_s is None
        else f"the total rate command {reference:g} deg/s"
    )
    for k in range(len(case)):
        c, r = int(case[k]), int(rows[k])
        nz = np.flatnonzero(rate_deg_s[k])
        mags = np.abs(rate_deg_s[k, nz])
        if equal_split and len(nz) > 1:
            # The paper splits the total rate equally over the commanded axes (0.3/sqrt(k)).
            mid = float(np.median(mags))
            dev = np.abs(mags - mid) / mid
            if dev.max() > RATE_RTOL:
                axis = int(nz[int(np.argmax(dev))])
                raise cell_error(
                    file,
                    f"unequal magnitudes on the commanded axes (others {mid:g} deg/s, "
                    f"tolerance {RATE_RTOL:g} relative)",
                    row=r,
                    case=c,
                    column=RATE_COLUMNS[axis],
                    value=float(rate_deg_s[k, axis]),
                )
        if abs(norms[k] - reference) > RATE_RTOL * reference:
            axis = int(nz[0])
            raise cell_error(
                file,
                f"total rate {norms[k]:.6g} deg/s differs from {what} by more than "
                f"{RATE_RTOL:g} relative",
                row=r,
                case=c,
                column=RATE_COLUMNS[axis],
                value=float(rate_deg_s[k, axis]),
            )


def load_rate_cases(
    path: PathLike | None = None, *, total_rate_deg_s: float | None = PAPER_TOTAL_RATE_DEG_S
) -> RateCases:
    """Load the 26 rate-command cases (paper Table 3).

    Parameters
    ----------
    path : str or os.PathLike, optional
        A CSV with columns ``case, roll_deg_s, pitch_deg_s, yaw_deg_s`` (deg/s).  Default: the
        packaged (corrected) ``table3_rate_cases.csv``.
    total_rate_deg_s : float or None
        Required total rate ``|(roll, pitch, yaw)|`` of every case, deg/s, within
        ``RATE_RTOL`` relative.  Default 0.3 (paper section II).  None only requires all cases
        to share one total rate.  Either way every total must lie in the physical range
        ``RATE_TOTAL_MIN_DEG_S .. RATE_TOTAL_MAX_DEG_S`` (0.03..3 deg/s).

    Returns
    -------
    RateCases
        ``case`` (26,) = 1..26 and ``rate_cmd`` (26, 3) in rad/s.

    Raises
    ------
    rcsim.models.errors.InputError
        Missing/unknown column; bad cell; case numbers not exactly 1..26; an all-zero row;
        a row whose sign pattern is not its case's roll-major pattern (see
        :func:`sign_patterns`), e.g. a duplicate of another case; unequal magnitudes on the
        nonzero axes; a total rate outside the physical range (e.g. rates in rad/s); a total
        rate off the required one.
    """
    raw = read_raw(path, "table3_rate_cases.csv")
    check_columns(raw, ("case", *RATE_COLUMNS))
    case = index_column(raw, "case", N_CASES, "case")
    rate = np.array(
        [[number(raw, i, col, case=case[i]) for col in RATE_COLUMNS] for i in range(len(case))]
    )
    order = np.argsort(case)
    case, rate, rows = case[order], rate[order], order + 1
    check_rate_rows(
        raw.file,
        rows,
        case,
        rate,
        total_rate_deg_s=total_rate_deg_s,
        roll_major=True,
        equal_split=True,
    )
    return RateCases(case=case, rate_cmd=np.deg2rad(rate))


def rate_cases_at(total_rad_s: float) -> RateCases:
    """The 26 rate cases at total rate ``total_rad_s`` [rad/s] (a vehicle profile's
    ``rate_case_deg_s``).

    At the paper's 0.3 deg/s they are Table 3 as packaged (:func:`load_rate_cases`: the
    printed, corrected values, rounded to 4 decimals, with which every packaged table was
    made); at any other total the same sign patterns, split equally over their nonzero axes
    (paper sec. II), scaled exactly: ``pattern / |pattern| * total``.
    """
    if total_rad_s == float(np.deg2rad(PAPER_TOTAL_RATE_DEG_S)):
        return load_rate_cases()
    if not (np.isfinite(total_rad_s) and total_rad_s > 0):
        raise InputError(f"rate case total must be > 0 rad/s, got {total_rad_s}")
    patterns = sign_patterns().astype(float)
    rate = patterns / np.linalg.norm(patterns, axis=1, keepdims=True) * total_rad_s
    return RateCases(case=np.arange(1, N_CASES + 1), rate_cmd=rate)
