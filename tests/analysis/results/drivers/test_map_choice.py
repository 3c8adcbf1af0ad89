"""Issue 16, item 5: the kNN maps show what the evidence supports.

A case with many failures but no flagged per-case driver gets no map (the report says
"no flagged driver in this case"); a case whose failures one input drives gets a map of a
pair holding that input; the paper's Fig. 15 pair (Izz against yaw firing thrust) is mapped
beside the data's own pairs whenever both inputs are analysed.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from rcsim.analysis.results.drivers.inputs import load_runs
from rcsim.analysis.results.drivers.pipeline import FIG15_PAIR, Settings, analyze
from rcsim.analysis.results.drivers.report_sections import pairs as pairs_section


def _table(seed: int = 3) -> pd.DataFrame:
    rng = np.random.default_rng(np.random.SeedSequence([seed, 16]))
    n = 600
    X = pd.DataFrame(rng.standard_normal((n * 3, 6)), columns=["a", "b", "n1", "n2", "n3", "n4"])
    X[FIG15_PAIR[0]] = rng.standard_normal(n * 3)
    X[FIG15_PAIR[1]] = rng.standard_normal(n * 3)
    case = np.repeat(["random", "driven", "quiet"], n)
    u = rng.random(n * 3)
    failed = np.where(
        case == "random",
        u < 0.3,  # many failures, no input involved
        np.where(case == "driven", X["a"].to_numpy() > 0.8, u < 0.05),  # 'a' high fails
    )
    return X.assign(case=case, failed=failed)


def test_maps_follow_the_evidence_and_include_the_fig15_pair():
    table = _table()
    inputs = [c for c in table.columns if c not in ("case", "failed")]
    rs = load_runs(table, inputs=inputs, derived=False)
    res = analyze(rs, Settings(n_permutations=99, forest=False, n_maps=4, case_pairs=3))
    # The 'random' case holds the most failures (about 180 of 600) and no driver: no map.
    assert ("random", int(table.loc[table.case == "random", "failed"].sum())) in res.unmapped_cases
    mapped = {(case, tuple(m.feature_names_in_)) for case, m in res.maps}
    assert all(case != "random" for case, _ in mapped)
    # The 'driven' case is mapped on a pair holding its driver.
    assert any(case == "driven" and "a" in names for case, names in mapped)
    # The paper's pair is there, pooled, and says why.
    assert (None, FIG15_PAIR) in mapped
    assert any("Fig. 15" in why for why in res.map_reasons)
    assert len(res.map_reasons) == len(res.maps)
    html = "".join(str(b) for b in pairs_section(res).blocks)
    assert "no flagged driver in this case" in html
    # Issue 38: the paper's pair is noise here; its map must not read as where runs fail.
    assert "Fig. 15, for comparison; neither input is a flagged driver, so its shading" in html
    # The loop's report renders the same words (the conclusions object).
    from rcsim.analysis.results.drivers.conclusions import conclude

    whys = [why for _, why in conclude(res).maps]
    assert any(
        w.endswith("neither input is a flagged driver, so its shading is no finding") for w in whys
    )


def test_a_case_map_says_its_pair_rank():
    """Issue 38: a case's map caption said "the case's best" for a pair the case ranks fourth.
    Here the case's best pair is two views of one quantity (``a`` and ``a2 = a`` plus 1 %
    noise, rank correlation ~1), which the maps skip (a line, not two drivers): the pair
    mapped is not the case's first, and its caption gives its rank among the case's pairs
    (recounted from the case's pair table) instead of "the case's best"."""
    table = _table()
    rng = np.random.default_rng(7)
    table.insert(1, "a2", table["a"] + 0.01 * rng.standard_normal(len(table)))
    inputs = [c for c in table.columns if c not in ("case", "failed")]
    rs = load_runs(table, inputs=inputs, derived=False)
    res = analyze(rs, Settings(n_permutations=99, forest=False, n_maps=4, case_pairs=3))
    k = next(i for i, (case, _) in enumerate(res.maps) if case == "driven")
    a, b = res.maps[k][1].feature_names_in_
    case = next(c for c in res.cases if c.case == "driven")
    full = case.pairs.table().reset_index(drop=True)
    first = {full.loc[0, "factor_a"], full.loc[0, "factor_b"]}
    assert first == {"a", "a2"}  # the trap: the case's best pair is not mapped
    rank = 1 + int(
        np.flatnonzero(
            ((full["factor_a"] == a) & (full["factor_b"] == b))
            | ((full["factor_a"] == b) & (full["factor_b"] == a))
        )[0]
    )
    assert rank > 1
    why = res.map_reasons[k]
    assert "best pair by score" not in why
    assert why.startswith(f"ranked {rank} of the case's {len(full):,} pairs by score")
