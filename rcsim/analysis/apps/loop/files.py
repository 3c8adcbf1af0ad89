"""What the loop calls its table refined, and where it keeps a generated one (shared by the
stages, :mod:`rcsim.analysis.apps.loop.run`, and the report,
:mod:`rcsim.analysis.apps.loop.report`)."""

from __future__ import annotations

from pathlib import Path

from rcsim.models.tables import PAPER_LOOKUP_TABLES

#: The table setting that makes the loop generate its table first (stage ``generate``).
GENERATE = "generate"
#: Where the generated table goes in the loop directory (beside it: its recipe and settling
#: companion).
GENERATED_TABLE = "generated_table.csv"


def table_file(out: Path, table: str) -> str:
    """How the loop's campaigns name the table refined: the paper's by name, a file by its
    absolute path, the generated one by its path in ``out``."""
    if table == GENERATE:
        return str(Path(out) / GENERATED_TABLE)
    return table if table in PAPER_LOOKUP_TABLES else str(Path(table).absolute())
