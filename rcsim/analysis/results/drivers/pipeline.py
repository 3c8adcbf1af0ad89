"""The whole failure-driver analysis of one set of runs, as ``rcsim analyze`` performs it.

Order: single factors (KDE, permutation p-values) -> every pair -> stability (half samples)
-> random-forest second opinion -> per-case singles, and pairs for the cases that carry the
most failures -> kNN maps of the top pairs.  Everything is seeded from ``random_state``
through one ``SeedSequence``, spawned per step in a fixed order.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np
import pandas as pd

from rcsim.analysis.results.drivers.box_analysis import analyze_boxes
from rcsim.analysis.results.drivers.findings import family_levels
from rcsim.analysis.results.drivers.inputs import RunSet, load_runs
from rcsim.analysis.results.drivers.kde import maxt_p
from rcsim.analysis.results.drivers.maps import KNNFailureMap
from rcsim.analysis.results.drivers.outcomes import (
    OutcomeResults,
    analyze_outcomes,
    build_outcomes,
)
from rcsim.analysis.results.drivers.pairs import PairKDE
from rcsim.analysis.results.drivers.probabilities import add_to_results as add_probabilities
from rcsim.analysis.results.drivers.reading import analysed_rows, subsample_note
from rcsim.analysis.results.drivers.second_opinion import ForestImportance, compare
from rcsim.analysis.results.drivers.single import SingleFactorKDE
from rcsim.analysis.results.drivers.stability import HalfSampleStability
from rcsim.models.errors import InputError
from rcsim.spacecraft.dispersions import MAX_SEED

#: Fewest label permutations accepted: with B permutations the smallest p-value is 1/(B+1).
MIN_PERMUTATIONS = 19
#: Most label permutations: p-values resolved to 1e-5; beyond that only memory and time grow
#: (one permutation of a 10^6-run table is 8 MB per input).
MAX_PERMUTATIONS = 100_000


def _is_int(value) -> bool:
    return isinstance(value, (int, np.integer)) and not isinstance(value, bool)


@dataclass(frozen=True)
class Settings:
    """Knobs of :func:`analyze` (defaults are what ``rcsim analyze`` uses).

    Attributes
    ----------
    n_permutations : int
        Label permutations for the single-factor p-values (smallest p: 1/(B+1)), >= 19.
    pair_permutations : int or None
        For the pair p-values (joint test permutations and interaction test null draws),
        >= 19 (default: half of ``n_permutations``, at least 19): a pair
        permutation costs ~40x a single one (3,655 pairs of 16x16 cells against 86 inputs of
        32 bins), and 100 permutations resolve p = 0.01.
    n_splits : int
        Half-sample splits for stability (2 halves each).
    alpha : float
        Report-wise level: the most probability that the report shows any false flag.  It is
        split over the families of flags (single drivers, interactions, per-case drivers,
        outcome drivers) by :func:`~rcsim.analysis.results.drivers.findings.family_levels`;
        ``DriverResults.levels`` holds each family's share.
    min_case_failures : int
        A case is analysed on its own when it has at least this many failed and successful
        runs.
    case_pairs : int
        Cases (most failures first) whose pairs are analysed on their own.
    n_maps : int
        kNN maps drawn (top pooled pairs and the top pair of each such case).
    forest : bool
        Compute the random-forest second opinion.
    random_state : int
        Seed of the permutations and resamples, >= 0.
    bound_p : float
        The failure probability every "runs to bound" answers for: how many runs (at the
        observed rate) bound a failure probability below ``bound_p`` at 95 % confidence, in
        (0, 1) (:mod:`~rcsim.analysis.results.drivers.probabilities`).
    second_threshold : float
        Rate threshold [deg/s] of the threshold sensitivity, > 0: the campaign's criterion is
        analysed again with it beside the per-axis outcomes
        (:mod:`~rcsim.analysis.results.drivers.outcomes`).
    outcomes : bool
        Analyse the per-axis outcomes and the threshold sensitivity (single factors only).

    Raises
    ------
    InputError
        ``n_permutations`` or ``pair_permutations`` below 19, or a negative ``random_state``
        (the error's ``parameter`` is the field's name).
    """

    n_permutations: int = 200
    pair_permutations: int | None = None
    n_splits: int = 5
    alpha: float = 0.05
    min_case_failures: int = 5
    case_pairs: int = 2
    n_maps: int = 4
    forest: bool = True
    random_state: int = 0
    bound_p: float = 0.01
    second_threshold: float = 0.06
    outcomes: bool = True

    def __post_init__(self) -> None:
        # Fewer than 19 permutations cannot give p < 0.05 (smallest p is 1/(B+1)), so a
        # significance call would be impossible, silently.
        for name in ("n_permutations", "pair_permutations"):
            value = getattr(self, name)
            if value is None and name == "pair_permutations":
                continue
            if not _is_int(value) or value < MIN_PERMUTATIONS:
                raise InputError(
                    f"must be an integer >= {MIN_PERMUTATIONS} (fewer cannot reach "
                    f"p < 0.05), got {value!r}",
                    parameter=name,
                    value=value,
                )
        for name in ("n_permutations", "pair_permutations"):
            value = getattr(self, name)
            if value is not None and value > MAX_PERMUTATIONS:
                raise InputError(
                    f"must be at most {MAX_PERMUTATIONS:,} (p-values to 1e-5, far finer than "
                    f"any corrected threshold; more only costs memory and time), got {value!r}",
                    parameter=name,
                    value=value,
                )
        if not _is_int(self.random_state) or not 0 <= self.random_state <= MAX_SEED:
            raise InputError(
                f"must be an integer in 0..{MAX_SEED} (2^63 - 1), got {self.random_state!r}",
                parameter="random_state",
                value=self.random_state,
            )
        _check_extras(self)

    @property
    def pair_b(self) -> int:
        """Permutations actually used for pairs."""
        return self.pair_permutations or max(self.n_permutations // 2, MIN_PERMUTATIONS)


def _check_extras(st: Settings) -> None:
    """The probability and outcome settings (:attr:`Settings.bound_p`,
    :attr:`Settings.second_threshold`)."""
    if not isinstance(st.bound_p, (int, float)) or not 0.0 < st.bound_p < 1.0:
        raise InputError(
            f"must be a probability in (0, 1), got {st.bound_p!r}",
            parameter="bound_p",
            value=st.bound_p,
        )
    t = st.second_threshold
    if not isinstance(t, (int, float)) or not (np.isfinite(t) and t > 0):
        raise InputError(
            f"must be a rate threshold > 0 deg/s, got {t!r}",
            parameter="second_threshold",
            value=t,
        )


@dataclass
class CaseResult:
    """One case's counts and, when analysed on its own, its drivers.

    ``p_family`` (aligned with ``singles.feature_names_in_``) is corrected over the family of
    every (analysed case, input) test by max-T across all of them.
    """

    case: str
    runs: int
    failed: int
    singles: SingleFactorKDE | None = None
    pairs: PairKDE | None = None
    p_family: np.ndarray | None = None
    #: ``p_family`` below the per-case family's share of the budget (a flag the report shows).
    significant: np.ndarray | None = None


@dataclass
class DriverResults:
    """Everything :func:`analyze` found (``None`` parts were not computed: no failures)."""

    runset: RunSet
    settings: Settings
    singles: SingleFactorKDE | None = None
    pairs: PairKDE | None = None
    stability: HalfSampleStability | None = None
    forest: ForestImportance | None = None
    drivers: pd.DataFrame | None = None
    pair_table: pd.DataFrame | None = None
    cases: list = field(default_factory=list)
    maps: list = field(default_factory=list)  # (case or None, KNNFailureMap)
    # Why each map was drawn (aligned with ``maps``), and the cases left without a map.
    map_reasons: list = field(default_factory=list)
    unmapped_cases: list = field(default_factory=list)  # (case, failed runs)
    timings_s: dict = field(default_factory=dict)
    # PNG bytes of the figures shown both in the report and in figures/, rendered once
    # (filled by rcsim.analysis.results.drivers.figures.report_pngs).
    pngs: dict = field(default_factory=dict, repr=False)
    # Per-axis outcomes and the threshold sensitivity (rcsim.analysis.results.drivers.outcomes).
    outcomes: OutcomeResults | None = None
    # PRIM scenario-discovery boxes (rcsim.analysis.results.drivers.boxes.BoxResults).
    boxes: object = None
    # Each family's share of the report-wise level (rcsim.analysis.results.drivers.findings).
    levels: dict = field(default_factory=dict)

    @property
    def has_failures(self) -> bool:
        return self.singles is not None


def analyze(runset, settings: Settings = Settings(), *, vehicle=None) -> DriverResults:
    """Run the analysis (see the module docstring); returns :class:`DriverResults`.

    Parameters
    ----------
    runset : RunSet, pandas.DataFrame, str or Path
        Runs prepared by :func:`~rcsim.analysis.results.drivers.inputs.load_runs`, or what it reads
        (a campaign directory, a table file, a DataFrame of runs), loaded with its defaults
        (outcome ``failed``, the recorded inputs and the physics-aware factors; a table of more
        than :data:`~rcsim.analysis.results.drivers.reading.MAX_ANALYSED_RUNS` runs read as the
        subsample of ``settings.random_state``).
    settings : Settings
    vehicle : Vehicle, str or path, optional
        The vehicle the runs flew, for the physics-aware factors of a table or DataFrame (a
        campaign directory's manifest names its own); without one, none are derived
        (:func:`~rcsim.analysis.results.drivers.inputs.load_runs`).

    With no failed (or no successful) runs there is nothing to compare: the result holds the
    run set only and :attr:`DriverResults.has_failures` is False.
    """
    if not isinstance(runset, RunSet):
        runset = load_runs(runset, vehicle=vehicle, seed=settings.random_state)
    runset = _bounded(runset, settings.random_state)
    res = DriverResults(runset=runset, settings=settings)
    X, y, strata = runset.X, runset.y, runset.strata
    res.cases = _case_counts(runset)
    if y.all() or not y.any():
        return res
    res.levels = family_levels(settings.alpha, _families(res))
    seeds = np.random.SeedSequence(settings.random_state).spawn(6)
    clock = time.perf_counter()

    def lap(name):
        nonlocal clock
        now = time.perf_counter()
        res.timings_s[name] = now - clock
        clock = now

    B = settings.n_permutations
    B2 = settings.pair_b
    res.singles = SingleFactorKDE(
        n_permutations=B, random_state=np.random.default_rng(seeds[0])
    ).fit(X, y, strata)
    lap("singles")
    if X.shape[1] >= 2:
        res.pairs = PairKDE(
            n_permutations=B2,
            alpha=res.levels["interactions"],
            joint_level=settings.alpha,
            random_state=np.random.default_rng(seeds[1]),
        ).fit(X, y, strata, single_score=res.singles.score_)
        lap("pairs")
    minority = min(int(y.sum()), int((~y).sum()))
    if minority >= 4:
        res.stability = HalfSampleStability(
            settings.n_splits, random_state=np.random.default_rng(seeds[2])
        ).fit(X, y, res.singles, res.pairs, strata)
        lap("stability")
    drivers = res.singles.table()
    if res.stability is not None:
        stab = pd.Series(res.stability.single_stability_, index=res.singles.feature_names_in_)
        drivers["stability"] = drivers["factor"].map(stab)
    if settings.forest and minority >= 4:
        res.forest = ForestImportance(
            random_state=int(seeds[3].generate_state(1)[0] >> 1), n_jobs=2
        ).fit(X, y)
        drivers = compare(drivers, res.forest)
        lap("forest")
    drivers.insert(3, "significant", drivers["p_value"] < res.levels["singles"])
    res.drivers = drivers
    if res.pairs is not None:
        pt = res.pairs.table()
        if res.stability is not None and res.stability.pair_stability_ is not None:
            key = list(zip(pt["factor_a"], pt["factor_b"]))
            names = res.pairs.feature_names_in_
            stab = {
                (names[a], names[b]): s
                for (a, b), s in zip(res.pairs.pairs_, res.stability.pair_stability_)
            }
            pt["stability"] = [stab[k] for k in key]
        res.pair_table = pt
    _per_case(res, np.random.default_rng(seeds[4]))
    lap("cases")
    _maps(res, int(seeds[5].generate_state(1)[0] >> 1))
    lap("maps")
    _extras(res, lap)
    res.boxes = analyze_boxes(res)  # deterministic: needs no seed
    lap("boxes")
    return res


def _extras(res: DriverResults, lap) -> None:
    """Failure-region probabilities (drivers.csv) and the extra outcomes, after the rest and
    seeded on their own (the steps above draw exactly what they drew without them)."""
    add_probabilities(res)
    if res.settings.outcomes:
        seed = np.random.SeedSequence([int(res.settings.random_state), 0x0C7])
        res.outcomes = analyze_outcomes(res, np.random.default_rng(seed))
        lap("outcomes")


def _bounded(runset: RunSet, seed: int) -> RunSet:
    """``runset``, or the seeded uniform subsample of it
    (:func:`~rcsim.analysis.results.drivers.reading.analysed_rows`) when it holds more runs than
    the analysis reads at once: a run set built by hand.  :func:`load_runs` already reads a
    large table as that subsample (the same runs for the same seed), so its run sets pass
    through unchanged."""
    n = runset.y.size
    keep = analysed_rows(n, seed)
    if keep is None:
        return runset
    failed = int(runset.y.sum())
    note = subsample_note(keep.size, n, int(runset.y[keep].sum()), failed, seed)
    return replace(
        runset,
        runs=runset.runs.iloc[keep].reset_index(drop=True),
        X=runset.X.iloc[keep].reset_index(drop=True),
        y=runset.y[keep],
        strata=None if runset.strata is None else runset.strata[keep],
        notes=[*runset.notes, note],
        total_runs=n,
        total_failed=failed,
    )


def _families(res: DriverResults) -> list[str]:
    """The families of flags this analysis can show (its share of the budget goes to each):
    decided from the table's shape and its failure counts, never from the inputs' relation to
    failure (so the split is fixed before any test is looked at)."""
    rs, st = res.runset, res.settings
    out = ["singles"]
    if rs.X.shape[1] >= 2:
        out.append("interactions")
    if rs.strata is not None and len(res.cases) >= 2 and any(_analysed(c, st) for c in res.cases):
        out.append("per_case")
    if st.outcomes:
        extra = build_outcomes(rs, st.second_threshold).outcomes
        if any(o.y.any() and not o.y.all() for o in extra):
            out.append("outcomes")
    return out


def _analysed(c: CaseResult, st: Settings) -> bool:
    """A case is analysed on its own when it has enough failed and successful runs."""
    return c.failed >= st.min_case_failures and c.runs - c.failed >= st.min_case_failures


def _case_counts(runset: RunSet) -> list[CaseResult]:
    if runset.strata is None:
        return [CaseResult("all", int(runset.y.size), int(runset.y.sum()))]
    df = pd.DataFrame({"case": runset.strata, "failed": runset.y})
    g = df.groupby("case", sort=True)["failed"].agg(["size", "sum"])
    return [CaseResult(str(c), int(r["size"]), int(r["sum"])) for c, r in g.iterrows()]


def _per_case(res: DriverResults, rng: np.random.Generator) -> None:
    rs, st = res.runset, res.settings
    if rs.strata is None or len(res.cases) < 2:
        return
    by_fail = sorted(res.cases, key=lambda c: -c.failed)
    pair_cases = {c.case for c in by_fail[: st.case_pairs]}
    for c in res.cases:
        if not _analysed(c, st):
            continue
        rows = rs.strata == c.case
        X, y = rs.X[rows], rs.y[rows]
        # Within one case the firing-direction factors duplicate a pos/neg factor: keep one.
        X = X.loc[:, (X.nunique() > 1) & ~X.T.duplicated().to_numpy()]
        c.singles = SingleFactorKDE(n_permutations=st.n_permutations, random_state=rng).fit(X, y)
        if c.case in pair_cases and X.shape[1] >= 2:
            c.pairs = PairKDE(
                n_permutations=st.pair_b,
                alpha=res.levels.get("interactions", st.alpha),
                joint_level=st.alpha,
                random_state=rng,
            ).fit(X, y, single_score=c.singles.score_)
    case_family(res.cases, res.levels.get("per_case", st.alpha))


def case_family(cases: list, level: float) -> None:
    """Correct the per-case single tests over every (case, input) test at once.

    Each case's labels were permuted on their own, so permutation ``b`` of all cases together
    is one draw of the labels permuted within cases: the largest standardised null score over
    every case and input at draw ``b`` is the max-T null of the whole family, exact like the
    single-family one.  ``significant`` is ``p_family < level`` (the per-case family's share of
    the report-wise budget): the flags the report shows.  (Benjamini-Hochberg q-values over the
    same tests were listed in ``cases.csv`` beside the family-wise call once: a second
    significance column that meant something else than the report's.)
    """
    done = [c for c in cases if c.singles is not None]
    if not done:
        return
    max_null = np.max([c.singles.null_max_z_ for c in done], axis=0)
    for c in done:
        c.p_family = maxt_p(c.singles.z_, max_null)
        c.significant = c.p_family < level


#: Pairs whose rank correlation exceeds this are not mapped (two views of one quantity).
MAP_MAX_CORRELATION = 0.5


def _distinct_top(table: pd.DataFrame, X: pd.DataFrame, seen: set):
    """The best pair of ``table`` whose inputs are not two views of one quantity."""
    for _, row in table.iterrows():
        a, b = row["factor_a"], row["factor_b"]
        if frozenset((a, b)) in seen:
            continue
        if abs(X[a].corr(X[b], method="spearman")) <= MAP_MAX_CORRELATION:
            return a, b
    return None


def _case_pair_words(full: pd.DataFrame, pair) -> str:
    """Why a case's map shows ``pair``, with its rank among all the case's pairs by score: "the
    case's best" only when it is first (a pair may be passed over for holding no flagged
    driver, for being two views of one quantity, or for being mapped already)."""
    hit = full["factor_a"].eq(pair[0]) & full["factor_b"].eq(pair[1])
    hit |= full["factor_a"].eq(pair[1]) & full["factor_b"].eq(pair[0])
    rank = int(np.flatnonzero(hit.to_numpy())[0]) + 1
    if rank == 1:
        return "the case's best pair by score, holding a flagged driver"
    return (
        f"ranked {rank} of the case's {len(full):,} pairs by score: the best that holds a "
        "flagged driver, is not two views of one quantity and is not mapped already"
    )


#: Gambone's Fig. 15 pair (Izz against the yaw jets' thrust), mapped whenever both inputs are
#: analysed so a reader can set the paper's figure beside the data's own best pair.
FIG15_PAIR = ("izz_kg_m2", "thrust_yaw_fire_n")


def _maps(res: DriverResults, seed: int) -> None:
    """kNN maps of the pairs with the strongest evidence, and the paper's Fig. 15 pair.

    Per case (most failures first, at most half of ``n_maps``): only a case with a flagged
    per-case driver gets a map, of its best pair that holds such a driver; a case without one
    is listed in ``unmapped_cases`` ("no flagged driver in this case").  Pooled: the flagged
    interactions, then the best-scoring pairs of two flagged single drivers (a map of a flag,
    never of a pair only the joint test picks: that test is no flag, ``findings``).  Then
    :data:`FIG15_PAIR` when both inputs are analysed, labelled as the paper's comparison.
    Pairs of strongly rank-correlated inputs (e.g. a group's authority and its
    firing-direction copy) are skipped: their map is a line, not a picture of two drivers.
    """
    rs, st = res.runset, res.settings
    chosen: list = []
    seen: set = set()
    if res.pair_table is not None:
        per_case = 0
        for c in sorted(res.cases, key=lambda c: -c.failed):
            if per_case >= max(st.n_maps // 2, 1) or c.failed == 0:
                break
            drivers = (
                set()
                if c.singles is None or c.significant is None
                else {c.singles.feature_names_in_[j] for j in np.flatnonzero(c.significant)}
            )
            per_case += 1
            if not drivers:
                res.unmapped_cases.append((c.case, c.failed))
                continue
            if c.pairs is None:
                continue
            full = c.pairs.table().reset_index(drop=True)
            t = full[full["factor_a"].isin(drivers) | full["factor_b"].isin(drivers)]
            top = _distinct_top(t, rs.X[rs.strata == c.case], seen)
            if top is not None:
                chosen.append((c.case, *top, _case_pair_words(full, top)))
                seen.add(frozenset(top))
        pt, d = res.pair_table, res.drivers
        assert d is not None  # fitted before the maps
        flagged = set(d.loc[d["significant"], "factor"])
        both = pt["factor_a"].isin(flagged) & pt["factor_b"].isin(flagged)
        candidates = (
            (pt[pt["significant"]], "a flagged interaction"),
            (
                pt[~pt["significant"] & both],
                "the best-scoring pair of two flagged single drivers, not an interaction",
            ),
        )
        for table, why in candidates:
            while len(chosen) < st.n_maps:
                top = _distinct_top(table, rs.X, seen)
                if top is None:
                    break
                chosen.append((None, *top, why))
                seen.add(frozenset(top))
        a, b = FIG15_PAIR
        if a in rs.X.columns and b in rs.X.columns and frozenset(FIG15_PAIR) not in seen:
            chosen.append((None, a, b, "the pair of Gambone Fig. 15, for comparison"))
    for case, a, b, why in chosen:
        rows = np.ones(rs.y.size, bool) if case is None else rs.strata == case
        y = rs.y[rows]
        if y.all() or not y.any():
            continue
        m = KNNFailureMap(random_state=seed).fit(rs.X.loc[rows, [a, b]], y)
        res.maps.append((case, m))
        res.map_reasons.append(why)
