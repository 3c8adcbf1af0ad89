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
    from analysis.results.drivers.baseline import TTestBaseline
    from analysis.results.drivers.pairs import PairKDE
    from analysis.results.drivers.single import SingleFactorKDE

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
