"""The report page: a small template, generic blocks and the builder.

One file, no network: styles inline, figures as ``data:image/png;base64`` URIs, no external
script or font.  A tiny inline script records any JavaScript error into the page
(``#js-errors``) and marks the page loaded (``<body data-loaded="yes">``), so a headless
browser's DOM dump shows both -- that is how the Chromium test asserts "no console errors".
"""

from __future__ import annotations

import base64
import html
import io
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

from rcsim.models.atomic import atomic_write


@dataclass
class Section:
    """One section of a report.

    Attributes
    ----------
    title : str
    blocks : list of str
        HTML fragments (from :func:`text_block`, :func:`table_block`, :func:`figure_block`).
    anchor : str
        ``id`` of the section (for the contents list and for tests).
    """

    title: str
    blocks: list = field(default_factory=list)
    anchor: str = ""

    def __post_init__(self):
        if not self.anchor:
            self.anchor = "".join(ch if ch.isalnum() else "-" for ch in self.title.lower())


def text_block(*paragraphs: str, escape: bool = True) -> str:
    """Paragraphs of text (escaped unless ``escape=False``)."""
    return "".join(f"<p>{html.escape(p) if escape else p}</p>" for p in paragraphs)


def table_block(
    df: pd.DataFrame, caption: str = "", max_rows: int = 50, float_format: str = "{:.4g}"
) -> str:
    """An HTML table of ``df`` (first ``max_rows`` rows; a note says how many were left out)."""
    shown = df.head(max_rows)
    head = "".join(f"<th>{_breakable(str(c))}</th>" for c in shown.columns)
    rows = []
    # itertuples keeps each column's dtype (iterrows would turn the ints of a mixed row into
    # floats, printing case 3 as "3.00").
    for r in shown.itertuples(index=False):
        cells = []
        for v in r:
            if isinstance(v, float):
                text = "" if pd.isna(v) else float_format.format(v)
            else:
                text = str(v)
            cells.append(f"<td>{html.escape(text)}</td>")
        rows.append("<tr>" + "".join(cells) + "</tr>")
    more = (
        f"<p class='note'>{len(df) - max_rows} more rows in the CSV files.</p>"
        if len(df) > max_rows
        else ""
    )
    cap = f"<caption>{html.escape(caption)}</caption>" if caption else ""
    return (
        f"<div class='tablewrap'><table>{cap}<thead><tr>{head}</tr></thead>"
        f"<tbody>{''.join(rows)}</tbody></table></div>{more}"
    )


def _breakable(name: str) -> str:
    """``name`` escaped, with a line-break opportunity after each underscore: a long column
    name (``failed_search_before``) wraps at its words when the table is too wide for the
    page, instead of pushing the last columns off it."""
    return html.escape(name).replace("_", "_<wbr>")


def png_bytes(fig, dpi: int = 110) -> bytes:
    """A matplotlib figure as PNG bytes (made with the object API: nothing to close)."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi, bbox_inches="tight")
    return buf.getvalue()


def figure_block(png: bytes, caption: str, alt: str = "") -> str:
    """A figure inlined as base64 PNG, with a caption that says how to read it."""
    data = base64.b64encode(png).decode("ascii")
    return (
        f"<figure><img src='data:image/png;base64,{data}' alt='{html.escape(alt or caption)}'>"
        f"<figcaption>{html.escape(caption)}</figcaption></figure>"
    )


_STYLE = """
body{font-family:system-ui,-apple-system,'Segoe UI',sans-serif;margin:0;color:#1d2433;
background:#fafbfc;line-height:1.45}
header{background:#1d3557;color:#fff;padding:18px 32px}
header h1{margin:0 0 4px;font-size:24px} header p{margin:0;opacity:.85}
nav{padding:10px 32px;background:#e9eef5;font-size:14px}
nav a{margin-right:14px;color:#1d3557}
main{padding:8px 32px 40px;max-width:1200px}
section{background:#fff;border:1px solid #dde3ea;border-radius:6px;padding:8px 20px 16px;
margin:16px 0;min-width:0}
h2{color:#1d3557;border-bottom:2px solid #e63946;padding-bottom:4px}
table{border-collapse:collapse;font-size:13px;margin:8px 0}
th,td{border:1px solid #dde3ea;padding:3px 8px;text-align:left;vertical-align:top}
td{overflow-wrap:break-word}
th{background:#f1f4f8} caption{caption-side:top;text-align:left;font-weight:600;padding:4px 0}
.tablewrap{overflow-x:auto;max-width:100%} .note{color:#5b6472;font-size:13px}
figure{margin:12px 0} figure img{max-width:100%;height:auto;border:1px solid #eee}
figcaption{font-size:13px;color:#3d4654;max-width:900px}
code{background:#f1f4f8;padding:1px 4px;border-radius:3px}
pre{overflow-x:auto;max-width:100%}
#js-errors:empty{display:none} #js-errors{color:#b00;font-weight:bold}
@media print{
@page{size:A4;margin:12mm 10mm}
body{background:#fff;font-size:10pt;line-height:1.3}
header{background:none;color:#000;padding:0 0 6px;border-bottom:2px solid #1d3557}
header h1{font-size:16pt} header p{opacity:1}
nav{display:none}
main{max-width:none;padding:0}
section{border:none;border-radius:0;padding:0;margin:10px 0}
h2{font-size:13pt;break-after:avoid;page-break-after:avoid}
.tablewrap,pre{overflow:visible}
table{width:100%;font-size:7.5pt;margin:4px 0}
th,td{padding:1px 3px}
td{overflow-wrap:anywhere}
thead{display:table-header-group}
tr,figure,img{break-inside:avoid;page-break-inside:avoid}
caption{break-after:avoid}
figure img{max-width:100%;max-height:240mm;border:none}
figcaption{max-width:none;font-size:8.5pt}
pre{white-space:pre-wrap;overflow-wrap:anywhere;font-size:7pt}
}
"""

_SCRIPT_HEAD = """
window.addEventListener('error', function (e) {
  var box = document.getElementById('js-errors');
  if (box) { box.textContent += 'JS error: ' + e.message + '\\n'; }
});
"""

_SCRIPT_TAIL = "document.body.setAttribute('data-loaded', 'yes');"


def build_report(title: str, sections: list, subtitle: str = "") -> str:
    """The complete HTML page.

    Parameters
    ----------
    title : str
    sections : list of Section
    subtitle : str
    """
    nav = "".join(f"<a href='#{s.anchor}'>{html.escape(s.title)}</a>" for s in sections)
    body = "".join(
        f"<section id='{s.anchor}'><h2>{html.escape(s.title)}</h2>{''.join(s.blocks)}</section>"
        for s in sections
    )
    return (
        "<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>"
        "<meta name='viewport' content='width=device-width, initial-scale=1'>"
        f"<title>{html.escape(title)}</title><style>{_STYLE}</style>"
        f"<script>{_SCRIPT_HEAD}</script></head><body>"
        f"<header><h1>{html.escape(title)}</h1><p>{html.escape(subtitle)}</p></header>"
        f"<nav>{nav}</nav><main><pre id='js-errors'></pre>{body}</main>"
        f"<script>{_SCRIPT_TAIL}</script></body></html>"
    )


def write_report(path, title: str, sections: list, subtitle: str = "") -> Path:
    """Write :func:`build_report` to ``path`` (UTF-8), atomically; returns the path."""
    page = build_report(title, sections, subtitle)
    return atomic_write(path, lambda tmp: Path(tmp).write_text(page, encoding="utf-8"))
