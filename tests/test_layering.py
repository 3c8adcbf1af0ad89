"""The design card's one-way imports: models <- spacecraft <- lookup <- analysis.

Oracle: the user's design card ("Imports flow one way") and the namespaced install (the four
folders install as ``rcsim.models`` ... ``rcsim.analysis``).  The check reads every module's
import statements (AST), so a violation anywhere -- even in a function body -- fails, and so
does a bare ``import models`` (it would load a second copy of the module, or someone else's
package of that name).
"""
import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
LAYERS = ["models", "spacecraft", "lookup", "analysis"]


def _layers_imported(path: Path) -> tuple[set[str], set[str]]:
    """(layers imported as ``rcsim.<layer>``, bare layer names imported without ``rcsim.``)."""
    tree = ast.parse(path.read_text(), filename=str(path))
    modules = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            modules.extend(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            modules.append(node.module)
        elif isinstance(node, ast.Call) and getattr(node.func, "attr", "") == "import_module":
            modules.extend(a.value for a in node.args
                           if isinstance(a, ast.Constant) and isinstance(a.value, str))
    layered, bare = set(), set()
    for name in modules:
        parts = name.split(".")
        if parts[0] == "rcsim" and len(parts) > 1:
            layered.add(parts[1])
        elif parts[0] in LAYERS:
            bare.add(parts[0])
    return layered & set(LAYERS), bare


def _python_files(folder: Path):
    return sorted(p for p in folder.rglob("*.py") if "__pycache__" not in p.parts)


@pytest.mark.parametrize("layer", LAYERS)
def test_imports_flow_one_way(layer):
    allowed = set(LAYERS[: LAYERS.index(layer) + 1])
    bad = {}
    for path in _python_files(ROOT / layer):
        above = _layers_imported(path)[0] - allowed
        if above:
            bad[str(path.relative_to(ROOT))] = sorted(above)
    assert not bad, f"{layer} imports layers above it: {bad}"


@pytest.mark.parametrize("folder", LAYERS + ["tests", "benchmarks"])
def test_no_bare_layer_imports(folder):
    """Everything imports ``rcsim.<layer>``: a bare ``models`` is not our package once installed."""
    bad = {str(p.relative_to(ROOT)): sorted(_layers_imported(p)[1])
           for p in _python_files(ROOT / folder) if _layers_imported(p)[1]}
    assert not bad, f"bare (un-namespaced) imports: {bad}"


def test_the_checker_sees_violations(tmp_path):
    """The checker itself can fail: an upward and a bare import are both seen."""
    probe = tmp_path / "probe.py"
    probe.write_text("def f():\n    from rcsim.analysis.flight import fly\n    import models.tables\n")
    layered, bare = _layers_imported(probe)
    assert layered == {"analysis"} and bare == {"models"}
