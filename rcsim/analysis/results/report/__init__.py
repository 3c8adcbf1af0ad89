"""Self-contained HTML reports a review board can read without rcsim.

Owns the page template and generic blocks (:mod:`rcsim.analysis.results.report.html`: text, tables,
figures inlined as base64 PNG, no network).  A report is a list of :class:`Section`; each
analysis builds its own sections (e.g. :mod:`rcsim.analysis.results.drivers.report_sections`, the
loop's :mod:`rcsim.analysis.apps.loop.report`) and calls :func:`build_report`.  A kit: it knows no
analysis.

Must not import: rcsim.analysis.results.drivers, rcsim.analysis.results.scoring,
rcsim.analysis.engine, rcsim.analysis.apps, rcsim.spacecraft, rcsim.lookup.
"""

from rcsim.analysis.results.report.html import (
    Section,
    build_report,
    figure_block,
    table_block,
    text_block,
    write_report,
)

__all__ = ["Section", "build_report", "figure_block", "table_block", "text_block", "write_report"]
