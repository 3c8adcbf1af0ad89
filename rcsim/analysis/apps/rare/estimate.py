"""One rare-event estimation per case of a campaign spec, in an output directory that resumes.

Each case is estimated by ``K`` independent subset simulations (``--repeats``, default
:data:`REPEATS`), combined by :func:`rcsim.analysis.engine.rare.repeats.combine_repeats`: their
mean, with a CoV and an interval from their spread, never below Au & Beck's figure for the
mean (``docs/rare_events.md``).  The repeats run side by side on worker processes
(:mod:`.parallel`); each is a pure function of the spec, the case and its index, so the result
is the same bit for bit whatever the worker count.

Directory (``rcsim campaign rare SPEC --out DIR``):

* ``rare.json`` -- the command's record, written first and rewritten after each case: the
  spec (resolved), the method and its settings, the code version, and each finished case's
  result (:func:`result_record`, each repeat's figures beside the combined ones); its presence
  makes the directory ``campaign rare``'s, which only ``--resume`` continues
  (:data:`rcsim.analysis.engine.output_places.RESUMABLE`);
* ``cases/<case>/repeat-<k>/state.npz`` -- repeat ``k``'s subset simulation state after its last
  finished level (:class:`rcsim.analysis.engine.rare.state.SubsetState`): a killed estimation
  resumes there and re-flies at most one level of each repeat;
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

from rcsim.analysis.apps.rare.repeat import repeat_dir, write_atomic
from rcsim.analysis.apps.rare.settings import RareSettings
from rcsim.analysis.engine.rare import (
    RareEventResult,
    combine_repeats,
)
from rcsim.analysis.engine.rare.repeats import (
    ID_STRIDE,
    model_cov2,
)
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
) -> RareEventResult:
    """Estimate ``P(fail)`` of case ``case_index`` by its ``settings.repeats`` repeats, on up to
    ``workers`` processes or a Dask ``client``'s workers (:mod:`.parallel`); rows, points and
    states in ``case_dir``."""
    from rcsim.analysis.apps.rare.parallel import run_repeats

    parts = run_repeats(spec, case_index, settings, case_dir, progress, workers, client)
    if len(parts) == 1:
        return parts[0]
    return combine_repeats(parts, parts[0].confidence)


def case_rows(case_dir: Path, result: RareEventResult) -> pd.DataFrame:
    """The rows of every evaluation the result counts (batch files of later evaluations, of an
    abandoned level, are left out), with ``rare_repeat`` and ``rare_level``."""
    frames = []
    for k, part in enumerate(result.repeats or (result,)):
        found = sorted(repeat_dir(case_dir, k).glob("batch-*.parquet"))
        rows = pd.concat([pd.read_parquet(p) for p in found], ignore_index=True)
        rows = rows.drop_duplicates("rare_eval_id")
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


def result_record(result: RareEventResult, names: list[str], active: np.ndarray) -> dict:
    """The JSON record of a case's result (every figure a reader sees)."""
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
        "closest_failure": None,
    }
    cf = result.closest_failure
    if cf is not None:
        u = np.asarray(cf.u, float)
        rec["closest_failure"] = {
            "eval_id": int(cf.eval_id),
            "sigma_active": float(np.linalg.norm(u[active])),
            "sigma_all": float(cf.norm),
            "largest": [[n, float(v)] for n, v in cf.largest(names, count=3)],
        }
    return rec


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
