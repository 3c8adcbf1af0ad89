"""The limit state of one case of a campaign spec: ``g(u, ids)`` flies the runs of points ``u``.

A point ``u`` of the standard-normal space is a run's vehicle draws
(:mod:`rcsim.spacecraft.standard_space`: the dispersion normals, the tilt azimuths' normal
scores, the mass extras); its vehicle comes from
:func:`~rcsim.spacecraft.standard_space.vehicles_from_standard`, the same ``apply_draws`` as a
campaign's seeded runs (bit for bit, tested there).  Everything else a run draws -- sensor
noise and biases, valve timing -- comes from its run id's noise streams by the campaign's own
rule (:func:`rcsim.analysis.engine.campaign.effects.draw_effects`): a random nuisance, fresh for
every evaluation, which keeps subset simulation exact (``docs/rare_events.md``: a Markov move that
redraws the nuisance from its law is a Metropolis move on the joint space) and estimates
``P(fail)`` averaged over it, what plain Monte Carlo estimates.  Jet faults are not continuous
and are refused (:func:`check_continuous`).

Run identities.  A case is estimated by ``K`` independent repeats of ``N`` runs per level
(:mod:`rcsim.analysis.engine.rare.repeats`); evaluation ``e`` of repeat ``k`` has the global
evaluation id ``E = k 2^27 + e``.  Level 0 (``e < N``) of repeat ``k`` is campaign run
``c R + k N + e`` of case ``c`` (``R`` the spec's runs per case, when ``K N <= R``): level 0 of
the repeats *is* the campaign's first ``K N`` runs of that case, the same vehicles and noise.
Every later evaluation is run ``c 2^32 + 2^31 + E``, outside any campaign's range, its case
still ``run_id // 2^32`` (as level 0's, ``c 2^32 + k N + e``, when ``K N > R``); its vehicle is
recorded in its row and its ``u`` in the estimation's points file, so it replays.  With several
criteria, criterion ``i``'s chain evaluations carry ``i 2^23`` more
(:func:`rcsim.analysis.engine.rare.series.flight_ids`); level 0 is shared.

Criteria.  A run fails when any of the campaign's criteria fails (:func:`criteria_names`: the
rate, and the attitude, propellant exhaustion and each budget when the spec applies them); its
``margin`` column is their smallest term (:mod:`rcsim.analysis.engine.run_margin`).  The
estimation flies each criterion's own margin (:func:`criterion_margins`, from the same row), so
that a criterion that fails further out than another but more often is not missed
(:mod:`rcsim.analysis.engine.rare.series`).
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from rcsim.analysis.engine.rare.repeats import ID_STRIDE
from rcsim.analysis.engine.run_margin import JUST_BELOW_ZERO
from rcsim.models.errors import InputError
from rcsim.spacecraft import standard_space

if TYPE_CHECKING:
    from rcsim.analysis.engine.campaign.spec import CampaignSpec

#: Runs per case of the rows of chain evaluations: their case is ``run_id // CHAIN_STRIDE``.
CHAIN_STRIDE = 2**32
#: Offset of chain evaluations inside their case's range (above any level-0 id).
CHAIN_OFFSET = 2**31


def check_continuous(spec: CampaignSpec, where: str) -> None:
    """Refuse a spec whose runs draw inputs that are not continuous (jet faults: a Bernoulli
    and a jet index), with one line naming the table."""
    if not spec.effects.fault.is_none():
        raise InputError(
            f"{where}: [dispersions.fault] draws jet faults, which are not continuous: "
            "rare-event estimation needs every dispersed input continuous (estimate each "
            "fault case as its own spec, or use `rcsim campaign run`)",
            parameter="dispersions.fault",
            value="present",
        )


def criteria_names(spec: CampaignSpec) -> list[str]:
    """The criteria a run of ``spec`` can fail, by their names in the runs table's
    ``failed_by`` column: ``rate`` always; ``attitude`` with an attitude threshold;
    ``propellant_exhausted`` when the vehicle tracks propellant; each ``[failure]`` budget set."""
    from rcsim.analysis.engine.campaign.motion import budget_thresholds

    names = ["rate"]
    if spec.attitude_threshold_rad is not None:
        names.append("attitude")
    if spec.vehicle.tank(1) is not None:
        names.append("propellant_exhausted")
    names += list(budget_thresholds(_failure_table(spec)))
    return names


def _failure_table(spec: CampaignSpec) -> dict:
    return (getattr(spec, "resolved", None) or {}).get("failure") or {}


def criterion_margins(spec: CampaignSpec, rows: pd.DataFrame) -> np.ndarray:
    """(n, k) each criterion's margin (:func:`criteria_names`' order) of flown ``rows``.

    Each term is :func:`rcsim.analysis.engine.run_margin.criterion_terms`' for that criterion,
    in fractions of its threshold, recomputed from the row's outcome columns; its sign is the
    row's own verdict (``failed_by``), so that a criterion fails in the estimation exactly when
    the campaign says the run failed it (a term the row's rounding puts on the wrong side of 0
    keeps its size and takes the verdict's sign).  Propellant exhaustion, a step, is -1 or +1.
    A run whose simulation failed fails every criterion (NaN).
    """
    from rcsim.analysis.engine.campaign.motion import BUDGETS, budget_thresholds

    names = criteria_names(spec)
    if len(names) == 1:  # the margin column is the rate term itself, bit for bit
        return rows["margin"].to_numpy(float)[:, None]
    verdicts = [set(str(v).split("+")) for v in rows["failed_by"]]
    n = len(rows)
    cols = []
    for name in names:
        if name == "rate":
            thr = float(np.degrees(spec.rate_threshold_rad_s))
            axes = [f"final_rate_err_{a}_deg_s" for a in ("roll", "pitch", "yaw")]
            worst = np.max(np.abs(rows[axes].to_numpy(float)), axis=1)
            size = (thr - worst) / thr
        elif name == "attitude":
            thr = float(np.degrees(spec.attitude_threshold_rad or 0.0))
            size = (thr - rows["final_att_err_deg"].to_numpy(float)) / thr
        elif name == "propellant_exhausted":
            size = np.ones(n)
        else:
            limit = budget_thresholds(_failure_table(spec))[name]
            size = (limit - rows[BUDGETS[name][0]].to_numpy(float)) / limit
        failed = np.array([name in v for v in verdicts], bool)
        size = np.abs(size)
        cols.append(np.where(failed, -np.maximum(size, -JUST_BELOW_ZERO), size))
    margins = np.stack(cols, axis=1)
    margins[rows["sim_failed"].to_numpy(bool)] = np.nan
    return margins


def run_ids_of(
    spec: CampaignSpec, case_index: int, eval_ids: np.ndarray, n0: int, repeats: int = 1
) -> np.ndarray:
    """Run ids of global evaluation ids ``eval_ids`` of case ``case_index`` (module docstring);
    ``n0`` the level-0 size of each of the ``repeats``."""
    big = np.asarray(eval_ids, np.int64)
    k, e = big // ID_STRIDE, big % ID_STRIDE
    if in_campaign(spec, n0, repeats):
        first = np.int64(case_index) * spec.runs_per_case + k * n0 + e
    else:
        first = np.int64(case_index) * CHAIN_STRIDE + k * n0 + e
    chain = np.int64(case_index) * CHAIN_STRIDE + CHAIN_OFFSET + big
    return np.where(e < n0, first, chain)


def in_campaign(spec: CampaignSpec, n0: int, repeats: int) -> bool:
    """Whether level 0 of the ``repeats`` is the campaign's first ``repeats n0`` runs."""
    return repeats * n0 <= spec.runs_per_case


class CaseLimitState:
    """``g(u, ids) -> margins`` of case ``case_index`` of ``spec``; keeps the rows it flew.

    Parameters
    ----------
    spec : CampaignSpec
    case_index : int
    n0 : int
        Level-0 size of each repeat (module docstring).
    repeats : int
        ``K``, the independent repeats the case is estimated by (their ids, module docstring).
    on_rows : callable, optional
        Called with each batch's runs-table rows (a DataFrame) as soon as they are flown.
    nthread : int
        MuJoCo threads of a batch (0: MuJoCo's choice; 1 in a worker process of a pool).
    """

    def __init__(
        self,
        spec: CampaignSpec,
        case_index: int,
        n0: int,
        on_rows=None,
        repeats: int = 1,
        nthread: int = 0,
    ):
        from rcsim.analysis.engine.campaign.effects import adapt_options

        check_continuous(spec, spec.source)
        self.spec = spec
        self.case_index = int(case_index)
        self.case = spec.cases[self.case_index]
        self.n0 = int(n0)
        self.repeats = int(repeats)
        self.nthread = int(nthread)
        self.nominal = spec.vehicle.nominal(1)
        options = (
            {"adapt_options": adapt_options(spec.effects)} if spec.controller == "adaptive" else {}
        )
        self.controller = spec.make_controller(**options)
        self.on_rows = on_rows
        self.runs = 0
        self._chain_spec = replace(spec, runs_per_case=CHAIN_STRIDE)

    @property
    def dim(self) -> int:
        """Coordinates of ``u`` (:func:`~rcsim.spacecraft.standard_space.n_standard`)."""
        return standard_space.n_standard(self.nominal.n_jets, self.spec.sigmas.has_mass_extras)

    @property
    def names(self) -> list[str]:
        """Names of the coordinates, for the closest failure in words."""
        return standard_space.standard_names(self.nominal.n_jets, self.spec.sigmas.has_mass_extras)

    def level_zero(self, repeat: int = 0) -> np.ndarray:
        """(n0, dim) level 0's points of repeat ``repeat``: the campaign runs' own draws."""
        ids = run_ids_of(
            self.spec,
            self.case_index,
            repeat * ID_STRIDE + np.arange(self.n0),
            self.n0,
            self.repeats,
        )
        return standard_space.run_standard_normals(
            self.spec.seed, ids, self.nominal.n_jets, self.spec.sigmas.has_mass_extras
        )

    def rows(self, u: np.ndarray, eval_ids: np.ndarray) -> pd.DataFrame:
        """Fly the points ``u`` (n, dim) as evaluations ``eval_ids``: their runs-table rows
        (the campaign's columns, ``margin`` among them), in chunks of the spec's size."""
        size = self.spec.chunk_size
        parts = [
            self._fly(u[lo : lo + size], eval_ids[lo : lo + size])
            for lo in range(0, u.shape[0], size)
        ]
        return pd.concat(parts, ignore_index=True)

    def _fly(self, u: np.ndarray, eval_ids: np.ndarray) -> pd.DataFrame:
        from rcsim.analysis.engine.campaign.chunk import tabulate
        from rcsim.analysis.engine.campaign.effects import draw_effects
        from rcsim.analysis.engine.flight import fly_batch

        spec = self.spec
        run_ids = run_ids_of(spec, self.case_index, eval_ids, self.n0, self.repeats)
        dispersed = standard_space.vehicles_from_standard(self.nominal, spec.sigmas, u, run_ids)
        effects = draw_effects(spec.effects, spec.seed, run_ids, spec.n_jets)[0]
        history = fly_batch(
            [self.case] * u.shape[0],
            dispersed.params,
            self.controller,
            vehicle=spec.vehicle,
            nthread=self.nthread,
            **effects,
        )
        level_zero = bool(np.all(np.asarray(eval_ids) % ID_STRIDE < self.n0))
        campaign_rows = level_zero and in_campaign(spec, self.n0, self.repeats)
        rows = tabulate(spec if campaign_rows else self._chain_spec, history, dispersed)
        rows["rare_eval_id"] = np.asarray(eval_ids, np.int64)
        return rows

    @property
    def criteria(self) -> list[str]:
        """The criteria a run can fail (:func:`criteria_names`)."""
        return criteria_names(self.spec)

    def __call__(self, u: np.ndarray, eval_ids: np.ndarray) -> np.ndarray:
        """(n,) the runs' ``margin`` column: the smallest of their criteria's terms."""
        return self._flown(u, eval_ids)["margin"].to_numpy(float)

    def criterion_margins(self, u: np.ndarray, eval_ids: np.ndarray) -> np.ndarray:
        """(n, k) each criterion's margin of the runs (:func:`criterion_margins`)."""
        return criterion_margins(self.spec, self._flown(u, eval_ids))

    def _flown(self, u: np.ndarray, eval_ids: np.ndarray) -> pd.DataFrame:
        rows = self.rows(u, eval_ids)
        if self.on_rows is not None:
            self.on_rows(rows)
        self.runs += u.shape[0]
        return rows
