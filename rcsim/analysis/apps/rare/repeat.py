"""One repeat of a case's estimation: one subset simulation per criterion of the case's limit
state (:mod:`rcsim.analysis.engine.rare.series`; one for a rate-only spec), its rows, points,
states and progress log in its own folder ``cases/<case>/repeat-<k>/``
(:mod:`.estimate` names the layout; :mod:`.parallel` runs the repeats side by side).

A repeat is a pure function of the spec, the case, the settings and its index ``k``: its seed
is the case's root's child for ``k`` (:func:`rcsim.analysis.engine.rare.repeats.repeat_seed`),
its evaluation ids are global (``+ k 2^27``), its level 0 is the campaign's runs ``c R + k N``
onwards (:mod:`.flights`).  Files are written atomically (a temporary name, then a rename).
"""

from __future__ import annotations

import os
import secrets
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from rcsim.analysis.apps.rare.flights import CaseLimitState, criterion_margins
from rcsim.analysis.engine.rare.series import Record, SeriesRepeat, series_config, series_repeat

if TYPE_CHECKING:
    from rcsim.analysis.apps.rare.settings import RareSettings
    from rcsim.analysis.engine.campaign.spec import CampaignSpec


def write_atomic(path: Path, write: Callable[[str], object]) -> None:
    tmp = path.with_name(f"{path.name}.tmp-{secrets.token_hex(4)}")
    try:
        write(str(tmp))
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()


def _save_points(path: str, u: np.ndarray, ids: np.ndarray) -> None:
    with open(path, "wb") as fh:
        np.savez(fh, u=u, eval_id=ids)


def _batch_writer(case_dir: Path, names: list[str]) -> Callable[[pd.DataFrame], None]:
    def write(rows: pd.DataFrame) -> None:
        first = int(rows["rare_eval_id"].iloc[0])
        write_atomic(case_dir / f"batch-{first:012d}.parquet", lambda p: rows.to_parquet(p))

    return write


def case_seed(spec: CampaignSpec, case_index: int) -> np.random.SeedSequence:
    """The root of case ``case_index``'s estimation: ``SeedSequence(spec.seed, spawn_key=(2**62,
    case_index))``, a key no campaign run uses (run ``i``'s streams are ``(i, ...)``); repeat
    ``k`` draws from its child (:func:`rcsim.analysis.engine.rare.repeats.repeat_seed`)."""
    return np.random.SeedSequence(spec.seed, spawn_key=(2**62, case_index))


def repeat_dir(case_dir: Path, k: int) -> Path:
    return case_dir / f"repeat-{k}"


def state_path(where: Path, criterion: int, name: str) -> Path:
    """Criterion ``criterion``'s state file in its repeat's folder: ``state.npz`` for the
    first (the only one of a rate-only spec), ``state-<name>.npz`` for the others."""
    return where / ("state.npz" if criterion == 0 else f"state-{name}.npz")


def estimate_repeat(
    spec: CampaignSpec,
    case_index: int,
    settings: RareSettings,
    k: int,
    case_dir: Path,
    progress: Callable[[str], None] | None = None,
    nthread: int = 0,
) -> SeriesRepeat:
    """Repeat ``k`` of case ``case_index``: one subset simulation per criterion
    (:func:`rcsim.analysis.engine.rare.series.series_repeat`) from the shared level 0, the
    campaign's own runs (:mod:`.flights`); rows, points and states in
    ``case_dir/repeat-<k>/``; evaluation ids global (``+ k 2^27``, a criterion's chains
    ``+ i 2^23``).  Each run is flown once, whichever criterion's chain asks for it."""
    where = repeat_dir(case_dir, k)
    where.mkdir(parents=True, exist_ok=True)
    g = CaseLimitState(
        spec, case_index, settings.n_per_level, repeats=settings.repeats, nthread=nthread
    )
    g.on_rows = _batch_writer(where, g.names)
    criteria = g.criteria

    def g_flown(u: np.ndarray, ids: np.ndarray) -> np.ndarray:
        ids = np.asarray(ids, np.int64)
        margins = g.criterion_margins(u, ids)
        write_atomic(where / f"batch-{int(ids[0]):012d}.npz", lambda p: _save_points(p, u, ids))
        return margins

    name = spec.cases[case_index].name
    of = f" repeat {k + 1}/{settings.repeats}" if settings.repeats > 1 else ""

    def level_done(criterion: str, record) -> None:
        if progress is not None:
            which = f" {criterion}" if len(criteria) > 1 else ""
            progress(
                f"{name}{of}{which}: level {record.level} done, {record.n_evaluations:,} runs, "
                f"{record.n_failures} failed in the level, next threshold "
                f"{record.threshold:.3g}"
            )

    return series_repeat(
        g_flown,
        g.dim,
        series_config(settings.config(), settings.repeats, len(criteria)),
        criteria,
        k,
        seed=case_seed(spec, case_index),
        u0=g.level_zero(k),
        state_paths=[state_path(where, i, c) for i, c in enumerate(criteria)],
        progress=level_done,
        label=f"{spec.resolved!r} case {case_index} repeat {k} of {settings.repeats}",
        record=flown_record(spec, where, len(criteria)),
    )


def flown_record(spec: CampaignSpec, where: Path, k: int) -> Record:
    """The criteria's margins of the runs already flown in ``where`` (a resumed estimation's
    batch files): the estimation does not fly them again, and its joint estimate knows them.
    A batch is the same run, point and noise whenever it is flown (its id fixes them)."""
    record = Record(k)
    for path in sorted(where.glob("batch-*.parquet")):
        rows = pd.read_parquet(path)
        record.add(rows["rare_eval_id"].to_numpy(np.int64), criterion_margins(spec, rows))
    return record
