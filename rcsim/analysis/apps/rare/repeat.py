"""One repeat of a case's estimation: one subset simulation of the case's limit state, its rows,
points, state and progress log in its own folder ``cases/<case>/repeat-<k>/``
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

from rcsim.analysis.apps.rare.flights import CaseLimitState
from rcsim.analysis.engine.rare import RareEventResult, subset_simulation
from rcsim.analysis.engine.rare.repeats import ID_STRIDE, offset_result, repeat_seed

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


def estimate_repeat(
    spec: CampaignSpec,
    case_index: int,
    settings: RareSettings,
    k: int,
    case_dir: Path,
    progress: Callable[[str], None] | None = None,
    nthread: int = 0,
) -> RareEventResult:
    """Repeat ``k`` of case ``case_index``: one subset simulation, its rows, points and state in
    ``case_dir/repeat-<k>/``; its evaluation ids global (``+ k 2^27``).  Level 0 is the
    campaign's own runs (:mod:`.flights`), drawn from theirs."""
    where = repeat_dir(case_dir, k)
    where.mkdir(parents=True, exist_ok=True)
    g = CaseLimitState(
        spec, case_index, settings.n_per_level, repeats=settings.repeats, nthread=nthread
    )
    g.on_rows = _batch_writer(where, g.names)
    inner = g.__call__
    offset = k * ID_STRIDE

    def g_global(u: np.ndarray, ids: np.ndarray) -> np.ndarray:
        ids = np.asarray(ids, np.int64) + offset
        margins = inner(u, ids)
        write_atomic(where / f"batch-{int(ids[0]):012d}.npz", lambda p: _save_points(p, u, ids))
        return margins

    name = spec.cases[case_index].name
    of = f" repeat {k + 1}/{settings.repeats}" if settings.repeats > 1 else ""

    def level_done(record) -> None:
        if progress is not None:
            progress(
                f"{name}{of}: level {record.level} done, {record.n_evaluations:,} runs, "
                f"{record.n_failures} failed in the level, next threshold "
                f"{record.threshold:.3g}"
            )

    result = subset_simulation(
        g_global,
        g.dim,
        settings.config(),
        seed=repeat_seed(case_seed(spec, case_index), k),
        state_path=where / "state.npz",
        progress=level_done,
        u0=g.level_zero(k),
        label=f"{spec.resolved!r} case {case_index} repeat {k} of {settings.repeats}",
    )
    return offset_result(result, k)
