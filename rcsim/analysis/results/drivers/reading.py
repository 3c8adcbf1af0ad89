"""Reading a runs table for the driver analysis: only the rows analysed, and a memory estimate.

Beyond :data:`MAX_ANALYSED_RUNS` runs the analysis takes a seeded uniform random subsample
(:func:`analysed_rows`).  The subsample is chosen from the row count before the table is read,
and only its rows are read (a Parquet file one row group and a few columns at a time, a CSV
file skipping the other lines), so a table of 10^6 runs never sits in memory whole: the first
pass reads the outcome column (and the ``case`` column for a case filter) of every run, the
second every column of the runs analysed.  A table that fits is read whole, as it always was.

:func:`check_memory` refuses, before reading anything, a table whose analysis would need more
than half of the machine's memory (:func:`rcsim.spacecraft.guards.memory_budget_bytes`), e.g.
thousands of columns, or 10^9 runs whose outcome column alone is gigabytes, unless the caller
says ``yes``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from rcsim.models.errors import InputError
from rcsim.spacecraft.guards import human_bytes, memory_budget_bytes

#: Most runs the analysis reads at once.  Beyond, it analyses a uniform random subsample of
#: this size (the failure fraction and every case's share kept in expectation) and says so:
#: 250,000 runs keep a million-run table within 4 GB and 5 minutes on 2 cores, and are ten
#: times the paper's 26,000-run campaign, so power is not what limits the result.
MAX_ANALYSED_RUNS = 250_000
#: Second word of the subsample's seed (``SeedSequence([seed, SUBSAMPLE_KEY])``): the
#: subsample is drawn apart from every other random step of the analysis.
SUBSAMPLE_KEY = 0x5AB5
#: Columns read from a Parquet row group at once: bounds what one read decodes (16 float64
#: columns of a 10^6-run row group, as ``pandas.to_parquet`` writes one, are 128 MB).
COLUMNS_PER_READ = 16


def analysed_rows(n_runs: int, seed: int) -> np.ndarray | None:
    """Positions of the runs analysed out of ``n_runs`` (sorted), or None when all are.

    A uniform draw of :data:`MAX_ANALYSED_RUNS` positions without replacement from
    ``SeedSequence([seed, SUBSAMPLE_KEY])``: the same seed gives the same runs.
    """
    if n_runs <= MAX_ANALYSED_RUNS:
        return None
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), SUBSAMPLE_KEY]))
    return np.sort(rng.choice(n_runs, MAX_ANALYSED_RUNS, replace=False))


def subsample_note(analysed: int, n_runs: int, failed_analysed: int, failed: int, seed) -> str:
    """What the report and the command say about a subsample: both counts, both failures."""
    return (
        f"analysed a uniform random subsample of {analysed:,} of the {n_runs:,} runs "
        f"(seed {seed}): {failed_analysed:,} failed in it, {failed:,} in all; rankings, "
        "p-values and regions are the subsample's"
    )


# ------------------------------------------------------------------------------- memory --
#: Bytes the analysis holds per run analysed and column of the table, at its peak, beyond
#: :data:`BASE_BYTES`: the runs frame, the inputs and derived factors as float64, their rank
#: scales and bin codes, the permutation draws, the forest's copies.  Measured peak RSS
#: (``benchmarks/analyze_scale.py``): campaign tables of 97 columns, 0.89 GB at
#: 100,000 runs and 1.41 GB at 10^6 (250,000 analysed), 36 bytes a cell between them;
#: synthetic tables of 63 columns, 0.69 GB at 10^5 and 1.28 GB at 10^6, 63 bytes a cell.
#: Rounded up to 64: the estimate is above every measurement (by 1.2-1.6x).
BYTES_PER_CELL = 64
#: Bytes per run of the whole table for the first pass: the outcome column as pyarrow and
#: pandas hold it, the ``case`` column's strings and their comparison, the positions kept
#: (measured: ~90 bytes a run with a case filter at 10^6 runs; rounded up).
FIRST_PASS_BYTES_PER_RUN = 96
#: The interpreter, numpy, pandas, pyarrow, scikit-learn and matplotlib imported (~0.26 GB),
#: and the analysis' fixed costs (figures, the forest; a 10,000-run table peaks at 0.48 GB).
BASE_BYTES = 512 * 2**20


def analysis_bytes(n_runs: int, n_columns: int) -> int:
    """Memory the analysis of a table of ``n_runs`` rows and ``n_columns`` columns needs at
    its peak [bytes] (an estimate: module constants)."""
    analysed = min(int(n_runs), MAX_ANALYSED_RUNS)
    return int(
        BASE_BYTES + int(n_runs) * FIRST_PASS_BYTES_PER_RUN + analysed * n_columns * BYTES_PER_CELL
    )


def check_memory(where, n_runs: int, n_columns: int, *, yes: bool) -> None:
    """Refuse (an :class:`InputError` on the ``yes`` parameter) an analysis whose estimate
    exceeds half the machine's memory, unless ``yes``; nothing has been read yet."""
    budget = memory_budget_bytes()
    need = analysis_bytes(n_runs, n_columns)
    if yes or budget is None or need <= budget:
        return
    analysed = min(int(n_runs), MAX_ANALYSED_RUNS)
    what = "them" if analysed == n_runs else f"{analysed:,} of them"
    raise InputError(
        f"not given: {where} has {n_runs:,} runs x {n_columns:,} column(s); analysing {what} "
        f"needs about {human_bytes(need)} of memory, more than the {human_bytes(budget)} "
        "allowed (half of this machine's memory); give it to start anyway, or analyse a "
        "smaller table",
        parameter="yes",
        value=False,
    )


# ------------------------------------------------------------------------------ readers --
class TableReader:
    """One table of runs, read in parts: its size, some columns of every row, some rows.

    Subclasses read a DataFrame, a Parquet file or a CSV file; each raises
    :class:`InputError` naming the file when it cannot be read.
    """

    where: object

    @property
    def n_rows(self) -> int:
        raise NotImplementedError

    @property
    def columns(self) -> list[str]:
        raise NotImplementedError

    def read_all(self) -> pd.DataFrame:
        """Every row and column, as the analysis always read a table that fits."""
        raise NotImplementedError

    def read_columns(self, columns: list[str]) -> pd.DataFrame:
        """``columns`` of every row."""
        raise NotImplementedError

    def read_rows(self, rows: np.ndarray) -> pd.DataFrame:
        """Every column of the rows at positions ``rows`` (sorted), index 0..len(rows)-1."""
        raise NotImplementedError


class FrameReader(TableReader):
    """A DataFrame already in memory."""

    def __init__(self, frame: pd.DataFrame):
        self.frame = frame.reset_index(drop=True)
        self.where = "the DataFrame"

    @property
    def n_rows(self) -> int:
        return len(self.frame)

    @property
    def columns(self) -> list[str]:
        return list(self.frame.columns)

    def read_all(self) -> pd.DataFrame:
        return self.frame

    def read_columns(self, columns: list[str]) -> pd.DataFrame:
        return self.frame[columns]

    def read_rows(self, rows: np.ndarray) -> pd.DataFrame:
        return self.frame.iloc[rows].reset_index(drop=True)


def _unreadable(path: Path, exc: BaseException) -> InputError:
    text = str(exc).splitlines()[0] if str(exc) else ""
    if isinstance(exc, (OSError, ValueError, ImportError)):
        return InputError(f"{path}: cannot read the table ({text})")
    # pyarrow raises its own types for corrupt files
    return InputError(f"{path}: cannot read the table ({type(exc).__name__}: {text})")


class ParquetReader(TableReader):
    """A Parquet file: its size and columns from the footer, rows by row group."""

    def __init__(self, path: Path):
        import pyarrow.parquet as pq

        self.path = self.where = path
        try:
            # buffer_size: stream each column chunk rather than hold it whole.
            self.file = pq.ParquetFile(path, buffer_size=8 * 2**20, pre_buffer=False)
        except Exception as exc:
            raise _unreadable(path, exc) from None
        meta = self.file.metadata
        self.group_rows = [meta.row_group(g).num_rows for g in range(meta.num_row_groups)]

    @property
    def n_rows(self) -> int:
        return int(self.file.metadata.num_rows)

    @property
    def columns(self) -> list[str]:
        return list(self.file.schema_arrow.names)

    def read_all(self) -> pd.DataFrame:
        try:
            return pd.read_parquet(self.path)
        except Exception as exc:
            raise _unreadable(self.path, exc) from None

    def read_columns(self, columns: list[str]) -> pd.DataFrame:
        try:
            return self.file.read(columns=columns).to_pandas()
        except Exception as exc:
            raise _unreadable(self.path, exc) from None

    def read_rows(self, rows: np.ndarray) -> pd.DataFrame:
        import pyarrow as pa

        names = self.columns
        parts, start = [], 0
        try:
            for g, size in enumerate(self.group_rows):
                lo, hi = np.searchsorted(rows, [start, start + size])
                if hi > lo:
                    take = pa.array(rows[lo:hi] - start)
                    cols: dict[str, object] = {}
                    for k in range(0, len(names), COLUMNS_PER_READ):
                        part = self.file.read_row_group(g, columns=names[k : k + COLUMNS_PER_READ])
                        cols.update(zip(part.column_names, part.take(take).columns))
                    parts.append(pa.table([cols[c] for c in names], names=names))
                start += size
            table = pa.concat_tables(parts) if parts else self.file.schema_arrow.empty_table()
            frame = table.to_pandas()
        except Exception as exc:
            raise _unreadable(self.path, exc) from None
        # A stored index (pandas' metadata) numbers the whole file's rows, not these.
        return frame.reset_index(drop=True)


class CsvReader(TableReader):
    """A CSV file: its header, a count of its rows, rows by skipping the others' lines."""

    def __init__(self, path: Path):
        self.path = self.where = path
        try:
            self._columns = [str(c) for c in pd.read_csv(path, nrows=0).columns]
        except Exception as exc:
            raise _unreadable(path, exc) from None
        self._n_rows: int | None = None

    @property
    def n_rows(self) -> int:
        if self._n_rows is None:
            first = self._columns[:1]
            self._n_rows = len(self.read_columns(first)) if first else 0
        return self._n_rows

    @property
    def columns(self) -> list[str]:
        return list(self._columns)

    def read_all(self) -> pd.DataFrame:
        try:
            return pd.read_csv(self.path)
        except Exception as exc:
            raise _unreadable(self.path, exc) from None

    def read_columns(self, columns: list[str]) -> pd.DataFrame:
        try:
            return pd.read_csv(self.path, usecols=columns)[columns]
        except Exception as exc:
            raise _unreadable(self.path, exc) from None

    def read_rows(self, rows: np.ndarray) -> pd.DataFrame:
        keep = np.zeros(self.n_rows + 1, bool)
        keep[0] = True  # the header line
        keep[np.asarray(rows) + 1] = True
        try:
            frame = pd.read_csv(self.path, skiprows=lambda i: i >= keep.size or not keep[i])
        except Exception as exc:
            raise _unreadable(self.path, exc) from None
        return frame.reset_index(drop=True)


def reader_for(path: Path) -> TableReader:
    """The reader of a table file by its suffix (``.parquet``, ``.csv``)."""
    suffix = path.suffix.lower()
    if suffix == ".parquet":
        return ParquetReader(path)
    if suffix == ".csv":
        return CsvReader(path)
    raise InputError(f"{path}: unknown table format {suffix!r}; use .parquet or .csv")
