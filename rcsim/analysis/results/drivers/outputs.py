"""Writing an analysis: ``drivers.csv``, ``pairs.csv``, ``cases.csv``, ``summary.csv``,
``outcomes.csv``, ``findings.csv`` (every flag the report shows), ``conclusions.json`` (what
every report of the analysis states, :mod:`.conclusions`), figures, ``report.html``.

Everything is written into a temporary directory that replaces the output directory only when
complete (:func:`rcsim.analysis.engine.output.atomic_dir`): a failure never leaves half-written
files.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from rcsim.analysis.engine.output import atomic_dir
from rcsim.analysis.results.drivers import report_boxes
from rcsim.analysis.results.drivers import report_sections as sections
from rcsim.analysis.results.drivers.conclusions import conclude
from rcsim.analysis.results.drivers.findings import findings, findings_frame
from rcsim.analysis.results.drivers.outcomes import outcome_table
from rcsim.analysis.results.drivers.pipeline import DriverResults
from rcsim.analysis.results.drivers.probabilities import overall_table, with_case_probabilities
from rcsim.analysis.results.report.html import build_report

DRIVER_COLUMNS = [
    "factor",
    "score",
    "p_value",
    "rank",
    "failure_region",
    "region_fail_share",
    "region_run_share",
    "significant",
    "stability",
    "forest_rank",
]
PAIR_COLUMNS = [
    "factor_a",
    "factor_b",
    "score",
    "p_value",
    "gain",
    "rank",
    "significant",
    "stability",
]


def case_table(res: DriverResults) -> pd.DataFrame:
    """Per case: runs, failures, share of all failures, and each per-case driver it flags.

    Listed are exactly the per-case drivers the report shows: ``p_value`` is the family-wise
    p-value over every (case, input) test (:func:`~.pipeline.case_family`) and ``significant``
    the report's flag, ``p_value`` below the per-case family's share of the
    report-wise level (``level``).  A case with none has one row with an empty factor.
    """
    rows = []
    nf = max(int(res.runset.y.sum()), 1)
    level = (res.levels or {}).get("per_case", float("nan"))
    empty = {
        "factor": "",
        "score": float("nan"),
        "p_value": float("nan"),
        "rank": 0,
        "significant": False,
        "level": level,
    }
    for c in res.cases:
        base = {
            "case": c.case,
            "runs": c.runs,
            "failed": c.failed,
            "share_of_all_failures": c.failed / nf,
        }
        if c.singles is None or c.significant is None:
            rows.append({**base, **empty})
            continue
        s = c.singles
        keep = np.flatnonzero(c.significant)
        keep = keep[np.argsort(s.rank_[keep], kind="stable")]
        if not keep.size:
            rows.append({**base, **empty})
        for j in keep:
            rows.append(
                {
                    **base,
                    "factor": s.feature_names_in_[j],
                    "score": s.score_[j],
                    "p_value": c.p_family[j],
                    "rank": int(s.rank_[j]),
                    "significant": True,
                    "level": level,
                }
            )
    return pd.DataFrame(rows)


#: The command named in the output directory's marker (:mod:`rcsim.analysis.engine.output`).
COMMAND = "analyze"


def write_analysis(res: DriverResults, out, *, overwrite: bool = False) -> Path:
    """Write every output of ``res`` into directory ``out``; returns the report path.

    ``overwrite`` replaces a directory an earlier ``rcsim analyze`` wrote (never another's).
    """
    title = f"Failure drivers: {res.runset.source.name}"
    subtitle = "rcsim analyze: which dispersions make runs fail, and where"
    html = build_report(title, sections.driver_sections(res), subtitle)
    with atomic_dir(out, COMMAND, overwrite=overwrite) as tmp:
        tmp = Path(tmp)
        if res.has_failures and res.drivers is not None:
            d = res.drivers
            d[
                [c for c in DRIVER_COLUMNS if c in d]
                + [c for c in d.columns if c not in DRIVER_COLUMNS]
            ].to_csv(tmp / "drivers.csv", index=False)
            if res.pair_table is not None:
                p = res.pair_table
                p[
                    [c for c in PAIR_COLUMNS if c in p]
                    + [c for c in p.columns if c not in PAIR_COLUMNS]
                ].to_csv(tmp / "pairs.csv", index=False)
            else:
                pd.DataFrame(columns=PAIR_COLUMNS[:6]).to_csv(tmp / "pairs.csv", index=False)
        else:
            pd.DataFrame(columns=DRIVER_COLUMNS[:5]).to_csv(tmp / "drivers.csv", index=False)
            pd.DataFrame(columns=PAIR_COLUMNS[:6]).to_csv(tmp / "pairs.csv", index=False)
        with_case_probabilities(case_table(res), res).to_csv(tmp / "cases.csv", index=False)
        findings_frame(findings(res)).to_csv(tmp / "findings.csv", index=False)
        conclude(res).write(tmp)
        _write_probabilities(res, tmp)
        _write_figures(res, tmp / "figures")
        report_boxes.write_files(res, tmp)
        (tmp / "report.html").write_text(html, encoding="utf-8")
    return Path(out) / "report.html"


def _write_probabilities(res: DriverResults, folder: Path) -> None:
    """The overall failure probability with its interval, ``summary.csv``, and the outcomes
    analysed, ``outcomes.csv`` (:mod:`.probabilities`, :mod:`.outcomes`)."""
    overall_table(res).to_csv(folder / "summary.csv", index=False)
    outcome_table(res).to_csv(folder / "outcomes.csv", index=False)


def _write_figures(res: DriverResults, folder: Path) -> None:
    """The report's figures also as PNG files (for slides): the same bytes as the report's."""
    from rcsim.analysis.results.drivers.figures import report_pngs

    folder.mkdir()
    for name, png in report_pngs(res).items():
        (folder / name).write_bytes(png)
