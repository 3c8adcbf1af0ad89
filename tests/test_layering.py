"""The design card's one-way imports: models <- spacecraft <- lookup <- analysis.

Oracle: the user's design card ("Imports flow one way").  The check reads every module's
import statements (AST), so a violation anywhere -- even in a function body -- fails.
"""
import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
LAYERS = ["models", "spacecraft", "lookup", "analysis"]


def _imported_packages(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(), filename=str(path))
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(alias.name.split(".")[0] for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module.split(".")[0])
    return names & set(LAYERS)


@pytest.mark.parametrize("layer", LAYERS)
def test_imports_flow_one_way(layer):
    allowed = set(LAYERS[: LAYERS.index(layer) + 1])
    bad = {
        str(path.relative_to(ROOT)): sorted(_imported_packages(path) - allowed)
        for path in (ROOT / layer).rglob("*.py")
        if _imported_packages(path) - allowed
    }
    assert not bad, f"{layer} imports layers above it: {bad}"
