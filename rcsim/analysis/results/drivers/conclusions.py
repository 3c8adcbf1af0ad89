"""The driver analysis's conclusions, in one object that every report renders.

``rcsim analyze``'s report and the loop's "Failure drivers" section state the same
conclusions: the findings (every flag, families named, the failures before the other outcomes),
the sentence naming the strongest driver, the ranking table (failure regions of flagged drivers
only) and why each failure map was drawn.  They are worked out once, here, from a
:class:`~rcsim.analysis.results.drivers.pipeline.DriverResults`, and written as
``conclusions.json`` beside the CSV files, so that a report rebuilt from the files later
(the loop's) says what the analysis said, word for word, without reading tables back and
concluding again.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field
from pathlib import Path

import pandas as pd

from rcsim.analysis.results.drivers.findings import Finding, findings, summary_lines

#: The file of :meth:`Conclusions.write`.
FILE = "conclusions.json"
#: Columns of the ranking table, in order (those the analysis has).
RANKING_COLUMNS = (
    "rank",
    "factor",
    "score",
    "p_value",
    "failure_region",
    "region_fail_share",
    "P(fail in region)",
    "stability",
    "forest_rank",
)
#: Ranking columns that state where an input makes runs fail: blank unless it is flagged.
REGION_COLUMNS = ("failure_region", "region_fail_share", "P(fail in region)")


@dataclass
class Conclusions:
    """What the analysis concludes, ready to render.

    Attributes
    ----------
    alpha : float
        The report-wise false-flag budget.
    findings : list of Finding
        Every flag (:func:`~.findings.findings`).
    summary : list of str
        The findings in words (:func:`~.findings.summary_lines`): a head line, then one line
        per family.
    strongest : str
        The sentence naming the strongest flagged driver and where its failures are, with a
        space after it; "" when no input is flagged (pooled or in a case).
    ranking : list of dict
        The driver ranking, best first: :data:`RANKING_COLUMNS`, the region columns blank for
        an input that is not flagged, and ``significant``.
    maps : list of (str, str)
        Each failure map's PNG name (``figures/``) and why it was drawn.
    """

    alpha: float
    findings: list = field(default_factory=list)
    summary: list = field(default_factory=list)
    strongest: str = ""
    ranking: list = field(default_factory=list)
    maps: list = field(default_factory=list)

    def ranking_frame(self) -> pd.DataFrame:
        """The ranking as a table (columns as :data:`RANKING_COLUMNS`, those present)."""
        frame = pd.DataFrame(self.ranking)
        return frame[[c for c in RANKING_COLUMNS if c in frame.columns]] if len(frame) else frame

    def summary_sentences(self) -> list[str]:
        """:attr:`summary` as sentences (capitalised, each ending with a full stop)."""
        head, *rest = self.summary
        return [f"{head[:1].upper()}{head[1:]}.", *(x.strip() + "." for x in rest)]

    def to_json(self) -> str:
        data = asdict(self)
        data["findings"] = [asdict(f) for f in self.findings]
        return json.dumps(data, indent=1, allow_nan=True)

    @classmethod
    def from_json(cls, text: str) -> Conclusions:
        data = json.loads(text)
        data["findings"] = [Finding(**f) for f in data.get("findings", [])]
        data["maps"] = [tuple(m) for m in data.get("maps", [])]
        return cls(**data)

    def write(self, folder: Path) -> None:
        (Path(folder) / FILE).write_text(self.to_json(), encoding="utf-8")

    @classmethod
    def read(cls, folder: Path) -> Conclusions | None:
        """The conclusions written into ``folder`` (None: none there)."""
        path = Path(folder) / FILE
        return cls.from_json(path.read_text(encoding="utf-8")) if path.is_file() else None


def conclude(res) -> Conclusions:
    """The :class:`Conclusions` of a
    :class:`~rcsim.analysis.results.drivers.pipeline.DriverResults` (computed once, kept on it)."""
    cached = getattr(res, "_conclusions", None)
    if cached is not None:
        return cached
    from rcsim.analysis.results.drivers import mechanism_text
    from rcsim.analysis.results.drivers.figures import map_png_names
    from rcsim.analysis.results.drivers.report_outcomes import region_column

    alpha = float(res.settings.alpha)
    out = Conclusions(alpha=alpha)
    if res.has_failures and res.drivers is not None:
        found = findings(res)
        out.findings = found
        out.summary = summary_lines(found, alpha)
        out.strongest = mechanism_text.strongest(res)
        d = res.drivers
        table = d.copy()
        if "region_fail_share" in table:
            table["P(fail in region)"] = region_column(d)
        flagged = d["significant"].astype(bool)
        for col in REGION_COLUMNS:
            if col in table:
                table[col] = table[col].astype(object).where(flagged, "")
        keep = [c for c in RANKING_COLUMNS if c in table.columns] + ["significant"]
        out.ranking = [
            {k: _plain(v) for k, v in row.items()} for row in table[keep].to_dict("records")
        ]
        out.maps = [
            (name, why + _no_finding(res, case, fmap, flagged))
            for name, why, (case, fmap) in zip(
                map_png_names(res), getattr(res, "map_reasons", []), res.maps
            )
        ]
    else:
        out.summary = summary_lines([], alpha)
    res._conclusions = out
    return out


def _no_finding(res, case, fmap, flagged) -> str:
    """ "; neither input is a flagged driver, ..." for a pooled map of two unflagged inputs (the
    paper's Fig. 15 pair is drawn for comparison whatever the evidence), else ""."""
    if case is not None or set(fmap.feature_names_in_) & set(res.drivers.loc[flagged, "factor"]):
        return ""
    return "; neither input is a flagged driver, so its shading is no finding"


def _plain(v):
    """A JSON-able scalar (numpy scalars as Python numbers)."""
    if hasattr(v, "item"):
        return v.item()
    return v
