"""Loading what ``rcsim analyze`` reads: a campaign directory or a Parquet/CSV table of runs.

A campaign directory (``manifest.json`` + ``runs.parquet``) gives the recorded inputs (the
columns of :func:`rcsim.analysis.engine.runs_table.input_columns`, per jet for as many jets as the
vehicle flown has, :func:`rcsim.analysis.engine.runs_table.recorded_jets`; with the products of
inertia and the sensor, timing and fault draws when the campaign recorded them), the
``failed`` outcome and the rate case of every run; any other table is taken as it is, with the
inputs named by the caller or, by default, the recorded-input columns when present, else every
numeric column other than the outcome, identifiers and the propellant, delta-v and pulse
outcomes (:func:`rcsim.analysis.engine.runs_table.is_propellant_motion`).  Physics-aware factors
(:mod:`rcsim.analysis.results.drivers.factors`) are added when the recorded inputs are
present. Every problem a user can fix raises
:class:`rcsim.models.errors.InputError` naming the file, the column and the value.

A table of more than :data:`~rcsim.analysis.results.drivers.reading.MAX_ANALYSED_RUNS` runs
(after a case filter) is not read whole: its outcome column (and ``case`` column) are read for
every run, then every column of a seeded uniform subsample of that many runs only
(:mod:`rcsim.analysis.results.drivers.reading`); the physics-aware factors are derived for
those runs alone, and the :class:`RunSet` says how many runs there were and how many failed.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from rcsim.analysis.engine import runs_table
from rcsim.analysis.results.drivers import reading
from rcsim.analysis.results.drivers.factors import fire_signs, mode_factors, physics_factors
from rcsim.analysis.results.drivers.reading import (
    FrameReader,
    ParquetReader,
    TableReader,
    check_memory,
    reader_for,
    subsample_note,
)
from rcsim.models.errors import InputError

#: Fewest runs an analysis accepts (a distribution needs more than a handful of points).
MIN_RUNS = 10
#: Columns that identify a run rather than describe it; never inputs by default.
ID_COLUMNS = tuple(c.name for c in runs_table.ID_COLUMNS)
#: Spread of an input, relative to its largest magnitude, at or below which it is constant:
#: rounding.  A vehicle's undispersed products of inertia, read back from each run's own
#: principal frame (its moments dispersed), vary by ~1e-14 relative; no dispersion comes near
#: 1e-9 (Table 5's smallest relative 3-sigma is CG x's, 0.01 m of 1.41 m).
ROUNDING_SPREAD = 1e-9


def is_constant(values: pd.Series) -> bool:
    """``values`` (finite numbers) do not vary beyond rounding (:data:`ROUNDING_SPREAD`)."""
    v = values.to_numpy(float)
    return bool(v.max() - v.min() <= ROUNDING_SPREAD * np.abs(v).max())


#: The column only a rare-event estimation's runs table has (``rcsim campaign rare``).
RARE_COLUMN = "rare_eval_id"
#: What a reader of such a table is told first.
RARE_NOTE = (
    "these runs are the conditional samples of a rare-event estimation (rcsim campaign rare: "
    "Markov chains inside ever rarer regions of the inputs), not a Monte Carlo sample: the "
    "drivers describe the failures found, but the failure fractions and probabilities below "
    "are those of the runs flown, not the cases' P(fail), which is in rare.json beside the table"
)


@dataclass
class RunSet:
    """Runs ready for the driver analysis.

    Attributes
    ----------
    source : Path
        The campaign directory or table file.
    kind : {"campaign", "table"}
    runs : DataFrame
        Every column of the runs read (after a ``case`` filter).
    X : DataFrame
        The analysed inputs (raw then derived), one row per run, all finite.
    raw_inputs, derived_inputs : list of str
    outcome : str
    y : ndarray of bool
        True where the run failed.
    strata : ndarray or None
        Case of every run (None: one group).
    manifest : dict or None
    notes : list of str
        Things the reader must know (inputs dropped as constant, factors not derived, a
        subsample analysed).
    total_runs, total_failed : int or None
        When only a subsample of the runs was analysed: how many runs the source had (after a
        ``case`` filter) and how many of them failed; None when every run was analysed.
    """

    source: Path
    kind: str
    runs: pd.DataFrame
    X: pd.DataFrame
    raw_inputs: list
    derived_inputs: list
    outcome: str
    y: np.ndarray
    strata: np.ndarray | None
    manifest: dict | None = None
    notes: list = field(default_factory=list)
    total_runs: int | None = None
    total_failed: int | None = None
    #: Inputs whose NaN means "does not apply" (:data:`runs_table.EFFECT_NOT_APPLICABLE`): per
    #: input, how many runs had no value and where they were placed instead (none left out).
    placed: dict = field(default_factory=dict)

    @property
    def conditional(self) -> bool:
        """The runs are a rare-event estimation's conditional samples (``rcsim campaign
        rare``'s ``runs.parquet``, recognised by its :data:`RARE_COLUMN`): their failure
        fraction is not a failure probability."""
        return RARE_COLUMN in self.runs.columns

    @property
    def subsampled(self) -> bool:
        """Only some of the source's runs were analysed."""
        return self.total_runs is not None and self.total_runs > self.y.size


def load_runs(
    path,
    inputs=None,
    outcome: str = "failed",
    case: str | None = None,
    derived: bool = True,
    vehicle=None,
    *,
    seed: int = 0,
    yes: bool = False,
) -> RunSet:
    """Read and validate runs for :func:`rcsim.analysis.results.drivers.pipeline.analyze`.

    Parameters
    ----------
    path : str, Path or pandas.DataFrame
        Campaign directory, a ``.parquet`` / ``.csv`` table with one row per run, or such a
        table already in memory (e.g. ``pd.read_parquet(...)`` filtered in a notebook).
    inputs : list of str, optional
        Input columns (raw or derived names); default as the module docstring says.
    outcome : str
        Binary outcome column (bool or 0/1); True/1 = failed.
    case : str, optional
        Keep only the runs of this case (column ``case``).
    derived : bool
        Add the physics-aware factors when the recorded inputs are present.
    vehicle : Vehicle, str, path, optional
        The vehicle the runs flew, for the physics-aware factors.  Default: the one a campaign
        directory's manifest names (its spec's ``vehicle``; the paper's when the spec names
        none); a table or DataFrame names none, and then no physics-aware factor is derived
        (a note says so): a vehicle is never guessed.
    seed : int
        Seed of the subsample of a table of more than
        :data:`~rcsim.analysis.results.drivers.reading.MAX_ANALYSED_RUNS` runs (``rcsim
        analyze`` passes its ``--seed``; the same seed gives the same runs).
    yes : bool
        Read a table whose analysis the memory estimate puts above half of this machine's
        memory (:func:`~rcsim.analysis.results.drivers.reading.check_memory`) anyway.

    Raises
    ------
    InputError
        Missing path or column, unreadable file, non-binary outcome, too few runs, NaN or
        non-numeric inputs, unknown case; a table too large for memory without ``yes``.
        Outcome and case are checked over every run; the inputs over the runs analysed.
    """
    if inputs is not None:  # a question about the arguments: before reading anything
        names = [str(c) for c in inputs]
        twice = sorted({c for c in names if names.count(c) > 1})
        if twice:
            raise InputError(
                f"names {twice[0]!r} twice; name each input once",
                parameter="inputs",
                value=twice[0],
            )
    source, reader, kind, manifest = _open_source(path)
    where = reader.where
    check_memory(where, reader.n_rows, len(reader.columns), yes=yes)
    runs, y, whole = _read_runs(reader, outcome, case, seed)

    notes: list[str] = [RARE_NOTE] if RARE_COLUMN in runs.columns else []
    jets = runs_table.recorded_jets(runs.columns)
    raw_cols = list(runs_table.input_names(jets))
    has_raw = jets > 0 and all(c in runs.columns for c in raw_cols)
    factors = pd.DataFrame(index=runs.index)
    flown = factor_vehicle(vehicle, manifest) if derived and has_raw else None
    if derived and has_raw and flown is None:
        notes.append(
            f"no vehicle named for {where}: no physics-aware factors derived (give the vehicle "
            "it flew: vehicle= in analyze/load_runs, --vehicle on the command line)"
        )
    elif derived and has_raw and flown is not None:
        if flown.n_jets != jets:  # a table of another vehicle's campaign
            notes.append(
                f"the table records {jets} jets and vehicle {flown.ref} has {flown.n_jets}: no "
                "physics-aware factors (give the vehicle the runs flew)"
            )
        else:
            signs = fire_signs(runs["case"]) if "case" in runs.columns else None
            if signs is None:
                notes.append("cases are not rate cases: firing-direction factors not derived")
            _check_numeric(runs, raw_cols, where)
            factors = physics_factors(runs, flown, signs)
            notes.append(f"physics-aware factors from vehicle {flown.ref} ({flown.name})")
    if derived and not has_raw:
        notes.append("the table lacks the recorded vehicle inputs: no physics-aware factors")
    if derived:
        # The modes' frequency ratios need no vehicle: the recorded coupled frequencies and
        # firing counts (factors.mode_factors).
        modal, unplaced = mode_factors(runs)
        if not modal.empty:
            factors = pd.concat([factors, modal], axis=1)
            if unplaced:
                notes.append(
                    f"mode_*_freq_ratio: {unplaced} run(s) without a firing frequency (no "
                    "firing, or no outcome): counted beyond the largest ratio"
                )

    if inputs is not None:
        inputs = [str(c) for c in inputs]
        if not inputs:
            raise InputError("is empty", parameter="inputs", value=inputs)
        twice = sorted({c for c in inputs if inputs.count(c) > 1})
        if twice:
            raise InputError(
                f"names {twice[0]!r} twice; name each input once",
                parameter="inputs",
                value=twice[0],
            )
        unknown = [c for c in inputs if c not in runs.columns and c not in factors.columns]
        if unknown:
            raise InputError(
                f"{unknown[0]!r} is not a column of {where}"
                + (" (derived factors need the recorded inputs)" if not has_raw else ""),
                parameter="inputs",
                value=unknown[0],
            )
        if outcome in inputs:
            raise InputError(
                f"{outcome!r} is the outcome column; it cannot be an input",
                parameter="inputs",
                value=outcome,
            )
        raw = [c for c in inputs if c in runs.columns]
        der = [c for c in inputs if c not in runs.columns]
    else:
        if has_raw:
            # The vehicle dispersions, plus the sensor, timing and fault draws a campaign with
            # those effects recorded (they were once left out unless named).
            effects = [
                c.name
                for g in runs_table.EFFECT_GROUPS
                for c in runs_table.EFFECT_COLUMNS[g]
                if c.name in runs.columns
            ]
            # Products of inertia, recorded when the runs' principal axes are not B (constant
            # unless dispersed: left out below as not dispersed).
            products = [c for c in runs_table.PRODUCT_NAMES if c in runs.columns]
            # Each dispersed mode's recorded values (mode_<name>_freq_hz, ...).
            modes = [c for c in runs.columns if runs_table.mode_column_suffix(c) is not None]
            raw = list(raw_cols) + products + effects + modes
        else:
            raw = [
                c
                for c in runs.columns
                if c not in ID_COLUMNS
                and c != outcome
                and not runs_table.is_propellant_motion(c)  # outcomes of the run
                and c != "margin"  # the failure criterion's distance, an outcome
                and pd.api.types.is_numeric_dtype(runs[c])
                and not pd.api.types.is_bool_dtype(runs[c])
            ]
            if not raw:
                raise InputError(f"{where}: no numeric input columns besides the outcome")
            notes.append(
                "inputs: every numeric column except the outcome, identifiers and the "
                "propellant, delta-v and pulse outcomes"
            )
        der = list(factors.columns)
    placed: dict = {}
    runs = _fill_not_applicable(runs, raw, notes, placed)
    _check_numeric(runs, raw, where)
    X = pd.concat([runs[raw].astype(float), factors[der]], axis=1)
    constant = [c for c in X.columns if is_constant(X[c])]
    if constant:
        notes.append(f"constant (not dispersed) inputs left out: {', '.join(constant)}")
        X = X.drop(columns=constant)
        raw = [c for c in raw if c not in constant]
        der = [c for c in der if c not in constant]
    if X.shape[1] == 0:
        raise InputError(f"{where}: every input is constant; nothing can drive the outcome")
    strata = runs["case"].astype(str).to_numpy() if "case" in runs.columns else None
    total_runs = total_failed = None
    if whole is not None:  # a subsample: say so with both counts (the last note, as always)
        total_runs, total_failed = whole
        notes.append(subsample_note(y.size, total_runs, int(y.sum()), total_failed, seed))
    return RunSet(
        source=source,
        kind=kind,
        runs=runs,
        X=X,
        raw_inputs=raw,
        derived_inputs=der,
        outcome=outcome,
        y=y,
        strata=strata,
        manifest=manifest,
        notes=notes,
        placed=placed,
        total_runs=total_runs,
        total_failed=total_failed,
    )


def _open_source(path) -> tuple[Path, TableReader, str, dict | None]:
    """``(source, reader, kind, manifest)`` of a campaign directory, a table file or a
    DataFrame (``reader.where`` names it in messages); nothing of the runs is read yet."""
    if isinstance(path, pd.DataFrame):
        return Path("<DataFrame>"), FrameReader(path), "table", None
    source = Path(path)
    if source.is_dir():
        manifest_path, runs_path = source / runs_table.MANIFEST, source / runs_table.RUNS
        if not manifest_path.is_file() or not runs_path.is_file():
            raise InputError(
                f"{source}: not a campaign directory (needs manifest.json and "
                "runs.parquet) and not a table file",
                parameter="path",
                value=str(source),
            )
        try:
            manifest = json.loads(manifest_path.read_text())
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise InputError(f"{manifest_path}: cannot read the manifest ({exc})") from None
        return source, ParquetReader(runs_path), "campaign", manifest
    if source.is_file():
        return source, reader_for(source), "table", None
    raise InputError(
        f"{source}: no such campaign directory or table file", parameter="path", value=str(source)
    )


def _read_runs(
    reader: TableReader, outcome: str, case: str | None, seed: int
) -> tuple[pd.DataFrame, np.ndarray, tuple[int, int] | None]:
    """``(runs, y, whole)``: the runs analysed (after the ``case`` filter), their outcome, and
    ``(runs, failed)`` of all of them when only a subsample is analysed (else None).

    A table that fits is read whole, as always.  A larger one is read in two passes: the
    ``case`` and outcome columns of every run (checked there), then the runs analysed.
    """
    where = reader.where
    if reader.n_rows <= reading.MAX_ANALYSED_RUNS:
        runs = reader.read_all()
        if case is not None:
            runs = runs[_case_mask(runs, case, where)].reset_index(drop=True)
        _check_count(len(runs), where)
        return runs, _outcome(runs, outcome, where), None
    # Positions of the case's runs (None: every run); no array of every position is made.
    positions = None
    if case is not None:
        has_case = "case" in reader.columns
        cases = reader.read_columns(["case"]) if has_case else pd.DataFrame()
        positions = np.flatnonzero(_case_mask(cases, case, where))
        del cases
    n = reader.n_rows if positions is None else positions.size
    _check_count(n, where)
    column = reader.read_columns([outcome]) if outcome in reader.columns else pd.DataFrame()
    if positions is not None:
        column = column.iloc[positions]
    y_all = _outcome(column, outcome, where)  # every run's, checked
    del column
    keep = reading.analysed_rows(n, seed)
    if keep is None:  # the case's runs fit
        assert positions is not None  # else n = n_rows > MAX_ANALYSED_RUNS: a subsample
        return reader.read_rows(positions), y_all, None
    rows = keep if positions is None else positions[keep]
    return reader.read_rows(rows), y_all[keep], (int(n), int(y_all.sum()))


def _case_mask(runs: pd.DataFrame, case: str, where) -> np.ndarray:
    """The rows of ``case``; an InputError naming the cases when it is not one of them."""
    if "case" not in runs.columns:
        raise InputError(f"{case!r}: {where} has no 'case' column", parameter="case", value=case)
    names = [str(c) for c in pd.unique(runs["case"])]
    if str(case) not in names:
        raise InputError(
            f"{case!r} is not a case of {where}; cases: {', '.join(names[:30])}",
            parameter="case",
            value=case,
        )
    return (runs["case"].astype(str) == str(case)).to_numpy()


def _check_count(n: int, where) -> None:
    if n < MIN_RUNS:
        raise InputError(f"{where}: {n} run(s); the analysis needs at least {MIN_RUNS}")


def _outcome(runs: pd.DataFrame, outcome: str, where) -> np.ndarray:
    if outcome not in runs.columns:
        raise InputError(
            f"{outcome!r} is not a column of {where}", parameter="outcome", value=outcome
        )
    col = runs[outcome]
    if col.isna().any():
        raise InputError(
            f"{where}: outcome column {outcome!r} has {int(col.isna().sum())} missing values"
        )
    if pd.api.types.is_bool_dtype(col):
        return col.to_numpy(bool)
    if pd.api.types.is_numeric_dtype(col):
        values = set(np.unique(col.to_numpy()))
        if values <= {0, 1}:
            return col.to_numpy() == 1
    shown = ", ".join(repr(v) for v in list(pd.unique(col))[:5])
    raise InputError(
        f"{where}: outcome column {outcome!r} is not binary (bool or 0/1); values include {shown}"
    )


def _fill_not_applicable(
    runs: pd.DataFrame, cols, notes: list, placed: dict | None = None
) -> pd.DataFrame:
    """Effect columns' NaN ("does not apply", :data:`runs_table.EFFECT_NOT_APPLICABLE`) as
    numbers the rank-based analysis can use, each with a note saying what was done (and in
    ``placed``, per input, ``(runs without a value, why)``)."""
    fill = {}
    for c in cols:
        rule = runs_table.EFFECT_NOT_APPLICABLE.get(c)
        if rule is None or c not in runs.columns or not runs[c].isna().any():
            continue
        where_known = runs[c].dropna()
        if where_known.empty:  # never applies: a constant, left out below with the others
            fill[c] = 0.0
            continue
        place, why = rule
        fill[c] = float(where_known.max()) + 1.0 if place == "after" else 0.0
        notes.append(f"{c}: {int(runs[c].isna().sum())} run(s) without it; {why}")
        if placed is not None:
            placed[c] = (int(runs[c].isna().sum()), why)
    return runs.fillna(fill) if fill else runs


def _check_numeric(runs: pd.DataFrame, cols, where) -> None:
    for c in cols:
        col = runs[c]
        if not pd.api.types.is_numeric_dtype(col) or pd.api.types.is_bool_dtype(col):
            raise InputError(f"{where}: input column {c!r} is not numeric (dtype {col.dtype})")
        bad = ~np.isfinite(col.to_numpy(float))
        if bad.any():
            first = int(np.flatnonzero(bad)[0])
            label = (
                f"run_id {runs['run_id'].iloc[first]}"
                if "run_id" in runs.columns
                else f"row {first}"
            )
            raise InputError(
                f"{where}: input column {c!r} has {int(bad.sum())} NaN or "
                f"infinite value(s), first at {label}"
            )


def factor_vehicle(vehicle, manifest: dict | None):
    """The vehicle a run set's physics-aware factors are computed with: ``vehicle`` when given
    (a :class:`~rcsim.spacecraft.vehicle.Vehicle`, a packaged name or a file), else the
    one a campaign's manifest names (its spec's ``vehicle``, the paper's when the spec has
    none: a campaign without the key flew the paper's), else None."""
    from rcsim.spacecraft.vehicle import Vehicle

    if vehicle is not None:
        return Vehicle.load(vehicle)
    if manifest is None:
        return None
    return Vehicle.load((manifest.get("spec") or {}).get("vehicle"))
