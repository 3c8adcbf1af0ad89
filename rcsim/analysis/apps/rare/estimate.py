"""One rare-event estimation per case of a campaign spec, in an output directory that resumes.

Each case is estimated by ``K`` independent subset simulations (``--repeats``, default
:data:`REPEATS`), combined by :func:`rcsim.analysis.engine.rare.repeats.combine_repeats`: their
mean, with a CoV and an interval from their spread, never below Au & Beck's figure for the
mean (``docs/rare_events.md``).  A spec with several failure criteria (an attitude threshold,
tracked propellant, a budget) is estimated as a series system: each criterion by its own ``K``
subset simulations from the shared level 0, combined by series-system bounds
(:mod:`rcsim.analysis.engine.rare.series`); a criterion whose region was not explored gets no
bound and no interval, and the record says which and what would resolve it.  The repeats run
side by side on worker processes (:mod:`.parallel`); each is a pure function of the spec, the
case and its index, so the result is the same bit for bit whatever the worker count.

Directory (``rcsim campaign rare SPEC --out DIR``):

* ``rare.json`` -- the command's record, written first and rewritten after each case: the
  spec (resolved), the method and its settings, the code version, and each finished case's
  result (:func:`result_record`, each repeat's figures beside the combined ones); its presence
  makes the directory ``campaign rare``'s, which only ``--resume`` continues
  (:data:`rcsim.analysis.engine.output_places.RESUMABLE`);
* ``cases/<case>/repeat-<k>/state.npz`` (and ``state-<criterion>.npz`` for each criterion
  after the first) -- repeat ``k``'s subset simulation states after their last finished
  level (:class:`rcsim.analysis.engine.rare.state.SubsetState`): a killed estimation resumes
  there and re-flies at most one level of each repeat and criterion;
* ``cases/<case>/repeat-<k>/batch-<first evaluation id>.parquet`` and ``.npz`` -- each batch's
  runs-table rows (written as soon as the batch is flown) and its points ``u``.  A resumed
  estimation re-flies the unfinished level's batches with the same ids and points (its state
  fixes them), so a batch file is rewritten with the same content, never duplicated;
* ``runs.parquet`` -- when every case is done: every run flown, in the campaign's runs-table
  columns plus ``rare_eval_id``, ``rare_repeat`` and ``rare_level``; ``failures.parquet`` its
  failed runs.  ``rcsim analyze DIR/runs.parquet --vehicle V`` reads them; they are conditional
  samples (chains inside ever rarer regions), not a Monte Carlo sample: a driver analysis of
  them describes the failures found, and its rates are not the case's.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from rcsim.analysis.apps.rare.flights import criteria_names
from rcsim.analysis.apps.rare.repeat import repeat_dir, write_atomic
from rcsim.analysis.apps.rare.settings import RareSettings
from rcsim.analysis.engine.rare import (
    RareEventResult,
    SeriesResult,
    combine_repeats,
)
from rcsim.analysis.engine.rare.repeats import (
    ID_STRIDE,
    model_cov2,
)
from rcsim.analysis.engine.rare.series import CRITERION_STRIDE, combine_series_repeats
from rcsim.spacecraft import standard_space

if TYPE_CHECKING:
    from rcsim.analysis.engine.campaign.spec import CampaignSpec

COMMAND = "campaign rare"
RECORD = "rare.json"
CASES_DIR = "cases"
RUNS = "runs.parquet"
FAILURES = "failures.parquet"


def estimate_case(
    spec: CampaignSpec,
    case_index: int,
    settings: RareSettings,
    case_dir: Path,
    progress: Callable[[str], None] | None = None,
    workers: int = 1,
    client=None,
) -> RareEventResult | SeriesResult:
    """Estimate ``P(fail)`` of case ``case_index`` by its ``settings.repeats`` repeats, on up to
    ``workers`` processes or a Dask ``client``'s workers (:mod:`.parallel`); rows, points and
    states in ``case_dir``.  A rate-only spec gives the repeats' combination
    (:func:`~rcsim.analysis.engine.rare.repeats.combine_repeats`); a spec with several criteria
    their series combination (:func:`~rcsim.analysis.engine.rare.series.combine_series_repeats`,
    ``docs/rare_events.md``, "Several criteria")."""
    from rcsim.analysis.apps.rare.parallel import run_repeats

    outcomes = run_repeats(spec, case_index, settings, case_dir, progress, workers, client)
    names = criteria_names(spec)
    if len(names) == 1:
        parts = [o.parts[0] for o in outcomes]
        return parts[0] if len(parts) == 1 else combine_repeats(parts, parts[0].confidence)
    return combine_series_repeats(names, outcomes, settings.config().confidence, RESOLVE)


#: What resolves a criterion whose region was not explored, in the command's flags.
RESOLVE = "more runs per level (--runs-per-level) or a larger budget (--budget)"


def case_rows(case_dir: Path, result: RareEventResult | SeriesResult) -> pd.DataFrame:
    """The rows of every evaluation the result counts (batch files of later evaluations, of an
    abandoned level, are left out), with ``rare_repeat`` and ``rare_level`` (and, with several
    criteria, ``rare_criterion``: the criterion whose chain flew the run, empty for level 0,
    which every criterion shares)."""
    if isinstance(result, SeriesResult):
        return _series_rows(case_dir, result)
    frames = []
    for k, part in enumerate(result.repeats or (result,)):
        rows = _repeat_rows(case_dir, k)
        local = rows["rare_eval_id"].to_numpy() - k * ID_STRIDE
        rows = rows[local < part.n_evaluations].copy()
        bounds = np.array([r.n_evaluations for r in part.levels], np.int64)
        rows["rare_repeat"] = k
        rows["rare_level"] = np.searchsorted(
            bounds, rows["rare_eval_id"].to_numpy() - k * ID_STRIDE, side="right"
        )
        frames.append(rows)
    rows = pd.concat(frames, ignore_index=True)
    return rows.sort_values("rare_eval_id").reset_index(drop=True)


def _repeat_rows(case_dir: Path, k: int) -> pd.DataFrame:
    found = sorted(repeat_dir(case_dir, k).glob("batch-*.parquet"))
    rows = pd.concat([pd.read_parquet(p) for p in found], ignore_index=True)
    return rows.drop_duplicates("rare_eval_id")


def _series_rows(case_dir: Path, result: SeriesResult) -> pd.DataFrame:
    n0 = _level_zero_size(result, 0)
    frames = []
    for k in range(len(result.criteria[0].repeats or (result.criteria[0],))):
        rows = _repeat_rows(case_dir, k)
        local = rows["rare_eval_id"].to_numpy() % ID_STRIDE
        shared = local < n0
        which = np.where(shared, -1, local // CRITERION_STRIDE)
        e = np.where(shared, local, local % CRITERION_STRIDE)
        keep = np.zeros(len(rows), bool)
        level = np.zeros(len(rows), np.int64)
        for i, crit in enumerate(result.criteria):
            part = (crit.repeats or (crit,))[k]
            bounds = np.array([r.n_evaluations for r in part.levels], np.int64)
            mine = which == i
            keep |= mine & (e < part.n_evaluations)
            level[mine] = np.searchsorted(bounds, e[mine], side="right")
        keep |= shared
        rows = rows.assign(
            rare_repeat=k,
            rare_level=level,
            rare_criterion=[result.names[i] if i >= 0 else "" for i in which],
        )[keep]
        frames.append(rows)
    rows = pd.concat(frames, ignore_index=True)
    return rows.sort_values("rare_eval_id").reset_index(drop=True)


def _level_zero_size(result: SeriesResult, k: int) -> int:
    crit = result.criteria[0]
    return (crit.repeats or (crit,))[k].levels[0].n_samples


def result_record(
    result: RareEventResult | SeriesResult, names: list[str], active: np.ndarray
) -> dict:
    """The JSON record of a case's result (every figure a reader sees)."""
    if isinstance(result, SeriesResult):
        return _series_record(result, names, active)
    rec: dict = {
        "method": result.method,
        "status": result.status,
        "probability": result.probability,
        "cov": None if result.cov is None or not math.isfinite(result.cov) else result.cov,
        "interval": None if result.interval is None else list(result.interval),
        "upper_bound": result.upper_bound,
        "confidence": result.confidence,
        "runs": result.n_evaluations,
        "failures_found": result.n_failures,
        "nonfinite": result.n_nonfinite,
        "reason": result.reason,
        "plain_mc_runs_same_cov": result.plain_mc_equivalent(),
        "levels": max(len(r.levels) for r in result.repeats or (result,)),
        "repeats": [_repeat_record(r) for r in result.repeats],
        "closest_failure": _closest_record(result.closest_failure, names, active),
    }
    return rec


def _closest_record(cf, names: list[str], active: np.ndarray) -> dict | None:
    if cf is None:
        return None
    u = np.asarray(cf.u, float)
    return {
        "eval_id": int(cf.eval_id),
        "sigma_active": float(np.linalg.norm(u[active])),
        "sigma_all": float(cf.norm),
        "largest": [[n, float(v)] for n, v in cf.largest(names, count=3)],
    }


def _series_record(result: SeriesResult, names: list[str], active: np.ndarray) -> dict:
    """A case of several criteria: the combined figures (no CoV: the interval is the series
    bounds') and each criterion's own record (:func:`result_record`) under ``criteria``."""
    closest = [r.closest_failure for r in result.criteria if r.closest_failure is not None]
    cf = min(closest, key=lambda f: f.norm) if closest else None
    k = len(result.names)
    repeats = len(result.criteria[0].repeats) or 1
    return {
        "method": (
            f"subset simulation per criterion ({k} criteria"
            + (f", {repeats} independent repeats each" if repeats > 1 else "")
            + "), series-system bounds"
        ),
        "status": result.status,
        "probability": result.probability,
        "cov": None,
        "interval": None if result.interval is None else list(result.interval),
        "upper_bound": result.upper_bound,
        "confidence": result.confidence,
        "criterion_confidence": result.criterion_confidence,
        "runs": result.n_evaluations,
        "failures_found": result.n_failures,
        "nonfinite": result.n_nonfinite,
        "reason": result.reason,
        "plain_mc_runs_same_cov": None,
        "levels": max(len(p.levels) for r in result.criteria for p in r.repeats or (r,)),
        "repeats": [],
        "criteria": {
            name: {
                **result_record(r, names, active),
                "weight": result.weights[i],
                "runs_failing_it": result.found_elsewhere[i],
            }
            for i, (name, r) in enumerate(zip(result.names, result.criteria))
        },
        "unexplored": list(result.unexplored),
        "closest_failure": _closest_record(cf, names, active),
    }


def _repeat_record(part: RareEventResult) -> dict:
    """One repeat's own figures: its CoV as one estimation's conservative bound, and Au & Beck's
    usual one, the model the combined CoV never goes below."""
    cov = part.cov if part.cov is not None and math.isfinite(part.cov) else None
    return {
        "status": part.status,
        "probability": part.probability,
        "cov_bound": cov,
        "cov_model": math.sqrt(model_cov2(part)),
        "upper_bound": part.upper_bound,
        "runs": part.n_evaluations,
        "levels": len(part.levels),
    }


def active_mask(spec: CampaignSpec) -> np.ndarray:
    """(dim,) bool: the coordinates the spec disperses (the closest failure's norm is over
    these, ``docs/rare_events.md``)."""
    return standard_space.active_coordinates(spec.sigmas, spec.vehicle.nominal(1).n_jets)


def write_record(out: Path, spec: CampaignSpec, settings: RareSettings, cases: dict) -> None:
    """``rare.json`` (module docstring), atomically."""
    from rcsim.analysis.engine.campaign.results import code_version

    text = json.dumps(
        {
            "command": COMMAND,
            "code": code_version(),
            "spec": spec.resolved,
            "settings": settings.record(),
            "cases": cases,
        },
        indent=2,
        default=float,
    )
    write_atomic(out / RECORD, lambda p: Path(p).write_text(text + "\n", encoding="utf-8"))


def check_resumable(out: Path, spec: CampaignSpec, settings: RareSettings) -> None:
    """Refuse to resume ``out`` with another spec or settings than it began with."""
    from rcsim.models.errors import InputError

    try:
        old = json.loads((out / RECORD).read_text())
    except (OSError, ValueError) as exc:
        raise InputError(f"{out / RECORD}: cannot read it to resume ({exc})") from None
    if (
        old.get("spec") != json.loads(json.dumps(spec.resolved, default=float))
        or old.get("settings") != settings.record()
    ):
        raise InputError(
            f"{out}: was begun with another spec or other settings "
            f"({old.get('settings')}); resume with the same ones or choose another directory",
            parameter="out",
            value=str(out),
        )


def estimate_cases(
    spec: CampaignSpec,
    case_indices: list[int],
    settings: RareSettings,
    out: Path,
    progress: Callable[[str], None] | None = None,
    workers: int = 1,
    client=None,
) -> dict[str, dict]:
    """Estimate each case in turn into ``out``, its repeats on up to ``workers`` processes (or
    a Dask ``client``'s workers); returns ``{case name: record}`` and writes
    ``runs.parquet``, ``failures.parquet`` and ``rare.json`` (module docstring)."""
    names = standard_space.standard_names(
        spec.vehicle.nominal(1).n_jets, spec.sigmas.has_mass_extras
    )
    active = active_mask(spec)
    records: dict[str, dict] = {}
    frames = []
    out.mkdir(parents=True, exist_ok=True)
    write_record(out, spec, settings, records)
    for c in case_indices:
        name = spec.cases[c].name
        case_dir = out / CASES_DIR / name
        result = estimate_case(spec, c, settings, case_dir, progress, workers, client)
        records[name] = result_record(result, names, active)
        frames.append(case_rows(case_dir, result))
        write_record(out, spec, settings, records)
    runs = pd.concat(frames, ignore_index=True)
    write_atomic(out / RUNS, lambda p: runs.to_parquet(p))
    failed = runs[runs["failed"].to_numpy(bool)].reset_index(drop=True)
    write_atomic(out / FAILURES, lambda p: failed.to_parquet(p))
    return records
