"""Where the packaged tables differ from the paper as printed: :class:`Correction` and
:func:`paper_corrections` (read from ``rcsim/models/data/corrections.csv``)."""

from __future__ import annotations

from dataclasses import dataclass

from rcsim.models.tables.schema import (
    PathLike,
    cell_error,
    check_columns,
    integer,
    number,
    read_raw,
)


@dataclass(frozen=True)
class Correction:
    """One cell where the packaged data differs from the paper as printed.

    Attributes
    ----------
    file : str
        Data file name, e.g. ``"table3_rate_cases.csv"``.
    case : int
        Case (or 1-based data row) of the corrected cell.
    column : str
        Column of the corrected cell, e.g. ``"roll_deg_s"``.
    paper_value : float
        Value printed in the paper, in the column's unit.
    corrected_value : float
        Value stored in the packaged file, in the column's unit.
    reason : str
        Why the printed value is wrong.
    """

    file: str
    case: int
    column: str
    paper_value: float
    corrected_value: float
    reason: str


def paper_corrections(path: PathLike | None = None) -> list[Correction]:
    """The cells where the packaged tables differ from the paper as printed.

    Read from ``rcsim/models/data/corrections.csv`` -- the same file ``SOURCES.md`` documents -- so
    the code, the data and the note cannot drift apart.

    Parameters
    ----------
    path : str or os.PathLike, optional
        A CSV with columns ``file, case, column, paper_value, corrected_value, reason``.
        Default: the packaged ``corrections.csv``.

    Returns
    -------
    list of Correction
        In file order.  Values are in the unit of the corrected column.

    Raises
    ------
    rcsim.models.errors.InputError
        Missing/unknown column, bad number, empty reason.
    """
    raw = read_raw(path, "corrections.csv")
    check_columns(raw, ("file", "case", "column", "paper_value", "corrected_value", "reason"))
    out = []
    for i in range(len(raw.rows)):
        for col in ("file", "column", "reason"):
            if raw.cell(i, col) == "":
                raise cell_error(raw.file, "empty cell", row=i + 1, column=col, value="")
        out.append(
            Correction(
                file=raw.cell(i, "file"),
                case=integer(raw, i, "case"),
                column=raw.cell(i, "column"),
                paper_value=number(raw, i, "paper_value"),
                corrected_value=number(raw, i, "corrected_value"),
                reason=raw.cell(i, "reason"),
            )
        )
    return out
