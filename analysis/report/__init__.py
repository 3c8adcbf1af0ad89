"""Self-contained HTML reports a review board can read without rcsim.

Owns the page template and generic blocks (:mod:`rcsim.analysis.report.html`: text, tables, figures
inlined as base64 PNG, no network) and the section builders of the failure-driver analysis
(:mod:`rcsim.analysis.report.sections`).  A report is a list of :class:`Section`; later analyses
(e.g. table refinement) add their own sections and call :func:`build_report`.  Imports
``rcsim.analysis.drivers`` results and the layers below; nothing below ``analysis`` imports it.
"""
from rcsim.analysis.report.html import Section, build_report, figure_block, table_block, text_block, write_report

__all__ = ["Section", "build_report", "figure_block", "table_block", "text_block",
           "write_report"]
