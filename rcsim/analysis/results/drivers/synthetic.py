"""Synthetic campaigns with a planted failure mechanism, to validate the driver analysis.

Every scenario draws ``n_runs`` runs of ``n_noise`` irrelevant standard-normal inputs
(``noise_01`` ...) plus the named inputs of the mechanism, and a failure label that depends only
on the mechanism's inputs:

``one-sided``
    Low thrust over inertia fails: ``(z_thrust - z_inertia) / sqrt(2) + 0.3 e < -1.8``
    (about 5 % failures).  True drivers: ``thrust``, ``inertia``; true pair: them.
``two-sided``
    Both hot and cold jets fail: ``|z_thrust| + 0.2 e > 2.0`` (about 5 %, half in each tail,
    so the failed runs' mean thrust equals the successful runs' -- a t-test sees nothing).
``pair``
    A pure interaction: a run fails with probability 0.2 when exactly one of ``a``, ``b`` is
    above its median, never otherwise.  ``P(fail | a)`` and ``P(fail | b)`` are both 0.1
    everywhere, so no single input shows it.
``few``
    Few failures, two-sided: ``|z_thrust| > 2.8`` (about 10 in 2,000 runs).
``null``
    Failure with probability 0.1 independent of every input; nothing is a driver.

``e`` is an independent standard normal (scatter of the mechanism).  Draws use one Generator
from ``SeedSequence(seed)``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd

SCENARIOS = ("one-sided", "two-sided", "pair", "few", "null")
#: True single drivers and the true pair of each scenario (None: no pair).
TRUTH = {
    "one-sided": (("thrust", "inertia"), ("thrust", "inertia")),
    "two-sided": (("thrust",), None),
    "pair": ((), ("a", "b")),
    "few": (("thrust",), None),
    "null": ((), None),
}


def planted_campaign(scenario: str, seed: int, n_runs: int = 2000, n_noise: int = 20):
    """One synthetic campaign.

    Parameters
    ----------
    scenario : one of :data:`SCENARIOS`
    seed : int
    n_runs, n_noise : int

    Returns
    -------
    X : DataFrame (n_runs, n_noise + 2)
        The mechanism's two inputs first (``thrust, inertia`` or ``a, b``), then ``noise_NN``.
    failed : ndarray of bool (n_runs,)
    """
    if scenario not in SCENARIOS:
        raise ValueError(f"scenario must be one of {SCENARIOS}, got {scenario!r}")
    rng = np.random.default_rng(np.random.SeedSequence(int(seed)))
    z = rng.standard_normal((n_runs, 2 + n_noise))
    e = rng.standard_normal(n_runs)
    u = rng.random(n_runs)
    names = ["a", "b"] if scenario == "pair" else ["thrust", "inertia"]
    names += [f"noise_{k + 1:02d}" for k in range(n_noise)]
    z1, z2 = z[:, 0], z[:, 1]
    if scenario == "one-sided":
        failed = (z1 - z2) / np.sqrt(2.0) + 0.3 * e < -1.8
    elif scenario == "two-sided":
        failed = np.abs(z1) + 0.2 * e > 2.0
    elif scenario == "pair":
        failed = ((z1 > 0) ^ (z2 > 0)) & (u < 0.2)
    elif scenario == "few":
        failed = np.abs(z1) > 2.8
    else:
        failed = u < 0.1
    X = pd.DataFrame(z, columns=names)
    if scenario in ("one-sided", "two-sided", "few"):
        # Physical units, so that the rank scale is shown to remove them: thrust ~ 22 +- 0.67 N,
        # inertia ~ 1400 +- 107 kg m^2 (Table 5-like 3-sigma of 2 N and 322 kg m^2).
        X["thrust"] = 22.0 + 2.0 / 3.0 * X["thrust"]
        X["inertia"] = 1400.0 + 322.0 / 3.0 * X["inertia"]
    return X, failed


def recovery(
    scenario: str,
    seeds,
    n_permutations: int = 100,
    n_runs: int = 2000,
    n_noise: int = 20,
    alpha: float = 0.05,
) -> dict:
    """How often the analysis (and the t-test baseline) recovers the planted truth.

    Per campaign: ``drivers_top`` -- every true driver ranks above every irrelevant input;
    ``drivers_significant`` -- every true driver has a corrected p < ``alpha``;
    ``pair_first`` -- the true pair ranks first among all pairs;
    ``false_positive`` -- some irrelevant input has a corrected p < ``alpha``;
    the ``ttest_`` keys are the same for Welch t-tests with Holm's correction.

    Returns
    -------
    dict
        Count of campaigns (out of ``len(seeds)``) meeting each criterion; criteria that do
        not apply to the scenario (no true driver, no true pair) are absent.
    """
    from rcsim.analysis.results.drivers.baseline import TTestBaseline
    from rcsim.analysis.results.drivers.pairs import PairKDE
    from rcsim.analysis.results.drivers.single import SingleFactorKDE

    drivers, pair = TRUTH[scenario]
    out: dict[str, int] = {"campaigns": 0}

    def add(key, hit):
        out[key] = out.get(key, 0) + int(bool(hit))

    for seed in seeds:
        X, y = planted_campaign(scenario, seed, n_runs, n_noise)
        names = list(X.columns)
        irr = np.array([n.startswith("noise_") for n in names])
        true = np.array([n in drivers for n in names])
        rs = np.random.default_rng(np.random.SeedSequence([int(seed), 1]))
        s = SingleFactorKDE(n_permutations=n_permutations, random_state=rs).fit(X, y)
        t = TTestBaseline().fit(X, y)
        out["campaigns"] += 1
        add("false_positive", (s.p_value_[irr] < alpha).any())
        add("ttest_false_positive", (t.p_value_[irr] < alpha).any())
        if true.any():
            add("drivers_top", s.rank_[true].max() < s.rank_[irr].min())
            add("drivers_significant", (s.p_value_[true] < alpha).all())
            add("ttest_drivers_top", t.rank_[true].max() < t.rank_[irr].min())
            add("ttest_drivers_significant", (t.p_value_[true] < alpha).all())
        if pair is not None:
            p = PairKDE(n_permutations=n_permutations, random_state=rs).fit(
                X, y, single_score=s.score_
            )
            first = p.pairs_[np.argmin(p.rank_)]
            add("pair_first", {names[first[0]], names[first[1]]} == set(pair))
            add("pair_significant", p.p_value_[np.argmin(p.rank_)] < alpha)
    return out


# --- Campaigns with rate cases: null calibration and case-aware planted truth ---------------

#: Scenarios of :func:`stratified_campaign`.
STRATIFIED = ("null", "single", "two-cases", "ratio-band", "ratio-offset", "pair", "tail")
#: Planted truth of each stratified scenario: pooled single drivers, per-case drivers
#: (case label -> inputs) and the true interaction (None: no pair may be an interaction).
STRATIFIED_TRUTH: dict = {
    "null": {"drivers": (), "cases": {}, "interaction": None},
    "single": {"drivers": ("a",), "cases": {}, "interaction": None},
    "two-cases": {
        "drivers": ("a", "b"),
        "cases": {"case-05": ("a",), "case-19": ("b",)},
        "interaction": None,
    },
    "ratio-band": {"drivers": ("a", "b"), "cases": {}, "interaction": ("a", "b")},
    "ratio-offset": {"drivers": ("a", "b"), "cases": {}, "interaction": ("a", "b")},
    "pair": {"drivers": ("a", "b"), "cases": {}, "interaction": ("a", "b")},
    "tail": {"drivers": ("a",), "cases": {}, "interaction": None},
}


def stratified_campaign(
    scenario: str,
    seed: int,
    n_cases: int = 26,
    runs_per_case: int = 1000,
    n_noise: int = 100,
    failure_rate: float = 0.05,
):
    """A campaign of ``n_cases`` rate cases with failures at random plus a planted mechanism.

    Every run fails at random with probability ``failure_rate`` (in every scenario); on top:

    ``null``
        Nothing: the inputs are ``n_noise`` standard normals ``noise_001`` ...
    ``single``
        One strong driver in every case and no interaction: a run with ``a`` in its top 20 %
        fails with probability 0.3 (``b`` is irrelevant).  Every pair holding ``a`` differs
        between failed and successful runs, none adds anything to ``a``.
    ``two-cases``
        Two drivers acting in two different cases: in ``case-05`` a run with ``a`` in its top
        20 % fails with probability 0.6, in ``case-19`` the same with ``b``.  Within any case
        at most one of them matters, so the pair is *not* an interaction.
    ``ratio-band``
        A narrow band of a ratio: ``a`` and ``b`` are log-normal (``exp(0.1 z)``) and a run
        whose ``d = log(a / b) / (0.1 sqrt 2)`` lies in ``[-0.1, 0.1]`` (8 % of runs, the
        ratio near its median) fails with probability 0.6, in every case.  Neither input alone
        shows it.
    ``ratio-offset``
        The same with the band off centre, ``d`` in ``[0.5, 0.75]`` (8 % of runs): both inputs
        then also act alone (failures at high ``a``, low ``b``).
    ``pair``
        The pure interaction of :func:`planted_campaign` in every case: probability 0.2 when
        exactly one of ``a``, ``b`` is above its median.
    ``tail``
        A narrow tail: a run with ``a`` in its top 3 % fails with probability 0.9 (``b`` is
        irrelevant); with ``failure_rate = 0.01`` the tail holds about three quarters of the
        failures, and the box that isolates it has density 0.9 in 3 % of the runs.

    Mechanism inputs ``a``, ``b`` come first (not in ``null``).  Cases are ``case-01`` ...,
    ``runs_per_case`` each.  Draws use one Generator from ``SeedSequence([seed, 26])``.

    Returns
    -------
    X : DataFrame, failed : ndarray of bool, case : ndarray of str
    """
    if scenario not in STRATIFIED:
        raise ValueError(f"scenario must be one of {STRATIFIED}, got {scenario!r}")
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 26]))
    n = n_cases * runs_per_case
    k = 0 if scenario == "null" else 2
    z = rng.standard_normal((n, k + n_noise))
    u = rng.random(n)
    v = rng.random(n)
    case_no = np.repeat(np.arange(1, n_cases + 1), runs_per_case)
    case = np.array([f"case-{c:02d}" for c in case_no])
    failed = u < failure_rate
    names = ["a", "b"][:k] + [f"noise_{j + 1:03d}" for j in range(n_noise)]
    X = pd.DataFrame(z, columns=names)
    hi = 0.8416  # upper 20 % of a standard normal
    if scenario == "single":
        failed |= (z[:, 0] > hi) & (v < 0.3)
    elif scenario == "two-cases":
        failed |= (case_no == 5) & (z[:, 0] > hi) & (v < 0.6)
        failed |= (case_no == 19) & (z[:, 1] > hi) & (v < 0.6)
    elif scenario in ("ratio-band", "ratio-offset"):
        d = (z[:, 0] - z[:, 1]) / np.sqrt(2.0)
        lo, hi = (-0.1, 0.1) if scenario == "ratio-band" else (0.5, 0.75)
        failed |= (d >= lo) & (d <= hi) & (v < 0.6)
        X["a"] = np.exp(0.1 * z[:, 0])
        X["b"] = np.exp(0.1 * z[:, 1])
    elif scenario == "pair":
        failed |= ((z[:, 0] > 0) ^ (z[:, 1] > 0)) & (v < 0.2)
    elif scenario == "tail":
        failed |= (z[:, 0] > TAIL_Z) & (v < 0.9)
    return X, failed, case


#: Upper 3 % point of a standard normal (the ``tail`` scenario's edge).
TAIL_Z = 1.8808

#: The synthetic campaigns' rate-error failure threshold [deg/s] (the campaigns' default one).
SYNTHETIC_THRESHOLD_DEG_S = 0.04


def axis_errors(
    failed: np.ndarray, seed: int, threshold: float = SYNTHETIC_THRESHOLD_DEG_S
) -> pd.DataFrame:
    """Final rate errors per axis for a synthetic campaign, so that the per-axis outcomes and
    the second threshold are analysed as on a real campaign: a failed run ends with one axis
    (roll, pitch or yaw at random) at ``|error|`` in ``[threshold, 2 threshold)``, its other
    axes and every axis of a successful run below ``0.9 threshold``.  Which axis fails (and
    whether it still fails at 1.5x the threshold) is independent of every input, so an input's
    per-axis drivers are those of the pooled outcome.  Drawn from ``SeedSequence([seed, 26,
    1])``, apart from the campaign's own draws."""
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 26, 1]))
    n = failed.size
    err = rng.uniform(0.0, 0.9 * threshold, (n, 3))
    axis = rng.integers(0, 3, n)
    big = rng.uniform(threshold, 2.0 * threshold, n)
    err[np.flatnonzero(failed), axis[failed]] = big[failed]
    names = [f"final_rate_err_{a}_deg_s" for a in ("roll", "pitch", "yaw")]
    return pd.DataFrame(err, columns=names)


def calibration_settings(**overrides):
    """The :class:`~rcsim.analysis.results.drivers.pipeline.Settings` of the calibration runs:
    defaults without the random-forest second opinion (no flag of its own) and one stability
    split (no flag either), which only cost time here."""
    from rcsim.analysis.results.drivers.pipeline import Settings

    kw: dict[str, Any] = {"forest": False, "n_splits": 1, "n_maps": 0, "case_pairs": 0}
    kw.update(overrides)
    return Settings(**kw)


def flags(scenario: str, seed: int, settings=None, **campaign) -> dict:
    """Analyse one :func:`stratified_campaign` with :func:`~.pipeline.analyze`; its flags.

    The table carries per-axis final rate errors (:func:`axis_errors`) and a 0.04 deg/s
    threshold, so the per-axis outcomes and the second threshold are analysed too: every family
    of flags the report shows is counted.

    Returns
    -------
    dict
        ``false_single`` / ``false_pair`` / ``false_case`` / ``false_outcome``: some input, pair,
        (case, input) or (outcome, input) is flagged that the planted truth does not hold;
        ``false_any``: any of them (the report-wise error: on the ``null`` scenario every flag
        is false); ``flags``: the number of flags the report shows
        (:func:`~.findings.findings`); ``true_case``: every planted per-case driver is flagged
        in its case; ``true_interaction``: the planted interaction is flagged;
        ``interaction_first``: it ranks first among the pairs; ``true_singles``: every pooled
        driver is flagged; ``found <truth>``: each planted driver (``found a``), per-case
        driver (``found a in case-05``) and interaction (``found a x b``) is flagged;
        ``unflagged_region_said``: the report's conclusions state a failure region of an input
        no family flagged (or name a strongest driver with nothing flagged).
    """
    from dataclasses import replace

    from rcsim.analysis.results.drivers.conclusions import conclude
    from rcsim.analysis.results.drivers.findings import findings
    from rcsim.analysis.results.drivers.inputs import load_runs
    from rcsim.analysis.results.drivers.pipeline import analyze

    settings = settings if settings is not None else calibration_settings()
    X, failed, case = stratified_campaign(scenario, seed, **campaign)
    truth = STRATIFIED_TRUTH[scenario]
    table = pd.concat([X, axis_errors(failed, seed)], axis=1).assign(case=case, failed=failed)
    rs = load_runs(table, inputs=list(X.columns), derived=False)
    rs = replace(rs, manifest={"thresholds": {"rate_error_deg_s": SYNTHETIC_THRESHOLD_DEG_S}})
    res = analyze(rs, settings)
    out: dict = {"false_single": False, "false_pair": False, "false_case": False}
    out.update({"false_outcome": False, "false_any": False, "flags": 0})
    d = res.drivers
    if not res.has_failures or d is None:
        return out
    found = findings(res)
    out["flags"] = len(found)
    # What the report says of where failures are (its conclusions): a region stated for an
    # input no family flagged, or a strongest-driver sentence with nothing flagged, would read
    # as a finding that is none.
    c = conclude(res)
    out["unflagged_region_said"] = bool(c.strongest and not found) or any(
        r.get("failure_region") and not r["significant"] for r in c.ranking
    )
    sig = {f.factor for f in found if f.family == "singles"}
    out["false_single"] = bool(sig - set(truth["drivers"]))
    if truth["drivers"]:
        out["true_singles"] = set(truth["drivers"]) <= sig
    inter = truth["interaction"]
    flagged = {frozenset((f.factor, f.factor_b)) for f in found if f.family == "interactions"}
    want = {frozenset(inter)} if inter else set()
    out["false_pair"] = bool(flagged - want)
    if inter and res.pair_table is not None:
        out["true_interaction"] = frozenset(inter) in flagged
        top = res.pair_table.iloc[0]
        out["interaction_first"] = {top["factor_a"], top["factor_b"]} == set(inter)
    found_case: dict = {}
    for f in found:
        if f.family == "per_case":
            found_case.setdefault(f.case, set()).add(f.factor)
    planted = truth["cases"]
    # A per-case flag is true when planted in that case, or when the input is a pooled driver
    # acting in every case (ratio band, pure pair, tail): those are drivers in each case too.
    everywhere = set(truth["drivers"]) if not planted else set()
    out["false_case"] = any(
        bool(f - set(planted.get(c, ())) - everywhere) for c, f in found_case.items()
    )
    if planted:
        out["true_case"] = all(set(v) <= found_case.get(c, set()) for c, v in planted.items())
    # Which axis fails is independent of the inputs (axis_errors): an outcome's true drivers
    # are the pooled ones and the planted per-case ones.
    acting = set(truth["drivers"]) | {f for v in planted.values() for f in v}
    out["false_outcome"] = any(f.family == "outcomes" and f.factor not in acting for f in found)
    out["false_any"] = any(out[k] for k in FALSE_FAMILIES)
    # Power, one key per planted truth: each pooled driver flagged, each per-case driver
    # flagged in its case, the interaction flagged.
    for f in truth["drivers"]:
        out[f"found {f}"] = f in sig
    for c, fs in planted.items():
        for f in fs:
            out[f"found {f} in {c}"] = f in found_case.get(c, set())
    if inter:
        out[f"found {inter[0]} x {inter[1]}"] = out.get("true_interaction", False)
    return out


#: The false-flag keys of :func:`flags`, one per family of the report's budget.
FALSE_FAMILIES = ("false_single", "false_pair", "false_case", "false_outcome")


def calibration(scenario: str, seeds, settings=None, **campaign) -> dict:
    """:func:`flags` over ``seeds``: the number of tables meeting each criterion."""
    out: dict = {"tables": 0}
    for seed in seeds:
        out["tables"] += 1
        for key, hit in flags(scenario, seed, settings, **campaign).items():
            out[key] = out.get(key, 0) + (int(hit) if key == "flags" else int(bool(hit)))
    return out
