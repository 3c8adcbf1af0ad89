"""The design card's one-way imports, down to the subpackages, read from the tree alone.

Oracles:

* the user's design card ("Imports flow one way"): ``models <- spacecraft <- lookup <- analysis``,
  the four layers that are the visible top of the one package ``rcsim``, with the top module
  (``rcsim/__init__.py``, ``rcsim/__main__.py``: version, command line, public API) above them;
* ``rcsim/analysis/__init__.py``: its three layers ``engine <- results <- apps``;
* every package's own ``__init__`` docstring, whose ``Must not import:`` and
  ``Only imported by:`` paragraphs are the rules of that package (the docstring is their one
  statement; this test reads it, so a rule cannot be written in one place and checked in
  another);
* no import cycles between modules, counting imports inside functions (a circle hidden in a
  function body is still a circle: it only moves the failure to run time).

Every import statement is read from the source (AST), so the tree is the whole truth: the
folders are the packages (``pyproject.toml``), nothing is mapped at install time.

In a rule, the name ``rcsim`` alone means the top module (``rcsim`` and ``rcsim.__main__``), not
the whole package: every module is inside ``rcsim``.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
#: The package's layers, lowest first; the top module last.
LAYERS = ["rcsim.models", "rcsim.spacecraft", "rcsim.lookup", "rcsim.analysis", "rcsim"]
#: What the name ``rcsim`` means in a rule or a layer: the top module, not its subpackages.
TOP = {"rcsim", "rcsim.__main__"}
#: The layers inside ``analysis``, lowest first.
ANALYSIS_LAYERS = ["rcsim.analysis.engine", "rcsim.analysis.results", "rcsim.analysis.apps"]


def _module_name(path: Path, root: Path = ROOT) -> str:
    parts = list(path.relative_to(root).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def imports_of(path: Path, root: Path = ROOT) -> set[str]:
    """Dotted names a module imports, anywhere in it (relative imports resolved).

    ``from a.b import c`` counts as importing ``a.b`` and ``a.b.c`` (``c`` may be a module);
    ``importlib.import_module("x.y")`` with a literal name counts as importing ``x.y``.
    """
    tree = ast.parse(path.read_text(), filename=str(path))
    here = _module_name(path, root).split(".")
    package = here if path.name == "__init__.py" else here[:-1]
    found: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[: len(package) - node.level + 1]
                module = ".".join(base + ([node.module] if node.module else []))
            else:
                module = node.module or ""
            found.add(module)
            found.update(f"{module}.{alias.name}" for alias in node.names)
        elif isinstance(node, ast.Call) and getattr(node.func, "attr", "") == "import_module":
            found.update(
                a.value
                for a in node.args
                if isinstance(a, ast.Constant) and isinstance(a.value, str)
            )
    return found


def _python_files(root: Path = ROOT) -> list[Path]:
    return sorted(p for p in (root / "rcsim").rglob("*.py") if "__pycache__" not in p.parts)


def _modules(root: Path = ROOT) -> dict[str, set[str]]:
    """Every module of the code base -> the modules of the code base it imports."""
    graph = {_module_name(p, root): imports_of(p, root) for p in _python_files(root)}
    known = set(graph)
    return {m: {i for i in imps if i in known and i != m} for m, imps in graph.items()}


def _within(name: str, prefix: str) -> bool:
    if prefix == "rcsim":
        return name in TOP
    return name == prefix or name.startswith(prefix + ".")


def _rank(name: str, order: list[str]) -> int | None:
    for k, prefix in enumerate(order):
        if _within(name, prefix):
            return k
    return None


def package_rules(root: Path = ROOT) -> dict[str, dict[str, list[str]]]:
    """Each package's stated rules: ``{package: {"must_not": [...], "only_by": [...]}}``."""
    rules = {}
    for init in sorted((root / "rcsim").rglob("__init__.py")):
        doc = ast.get_docstring(ast.parse(init.read_text())) or ""
        entry = {}
        for key, label in (("must_not", "Must not import:"), ("only_by", "Only imported by:")):
            match = re.search(re.escape(label) + r"(.*?)(?:\n\s*\n|\Z)", doc, re.S)
            if match:
                names = [
                    n.strip().rstrip(".") for n in match.group(1).replace("\n", " ").split(",")
                ]
                entry[key] = [n for n in names if n]
        if entry:
            rules[_module_name(init, root)] = entry
    return rules


def violations(root: Path = ROOT) -> list[str]:
    """Every broken rule, one line each (empty: the tree keeps its layers)."""
    graph = _modules(root)
    bad = []
    for module, imports in graph.items():
        for imp in sorted(imports):
            for order in (LAYERS, ANALYSIS_LAYERS):
                mine, theirs = _rank(module, order), _rank(imp, order)
                if mine is not None and theirs is not None and theirs > mine:
                    bad.append(f"{module} imports {imp}, a layer above it")
    for package, rule in package_rules(root).items():
        for module, imports in graph.items():
            if _within(module, package):
                for imp in sorted(imports):
                    hit = [f for f in rule.get("must_not", []) if _within(imp, f)]
                    if hit:
                        bad.append(f"{module} imports {imp}; {package} must not import {hit[0]}")
            elif "only_by" in rule and not any(_within(module, m) for m in rule["only_by"]):
                for imp in sorted(imports):
                    if _within(imp, package):
                        bad.append(
                            f"{module} imports {imp}; {package} is only imported by "
                            f"{', '.join(rule['only_by'])}"
                        )
    bad += [f"import cycle: {' -> '.join(c)}" for c in cycles(graph)]
    return bad


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """One cycle per strongly connected component of more than one module (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                out.append(sorted(component) + [sorted(component)[0]])

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def test_the_tree_keeps_its_layers():
    bad = violations()
    assert not bad, "\n".join(bad)


def test_every_package_states_its_rules_and_each_rule_names_a_real_package():
    # A rule naming a module that does not exist checks nothing (a typo, or a module moved).
    rules = package_rules()
    assert {
        "rcsim.models",
        "rcsim.spacecraft",
        "rcsim.lookup",
        "rcsim.analysis",
        "rcsim.analysis.engine",
        "rcsim.analysis.results",
        "rcsim.analysis.results.report",
        "rcsim.analysis.apps.cli",
    } <= set(rules)
    known = set(_modules())
    stale = [
        f"{package}: {name}"
        for package, rule in rules.items()
        for names in rule.values()
        for name in names
        if not any(_within(m, name) for m in known)
    ]
    assert not stale, f"rules naming no module of the tree: {stale}"


def test_no_top_level_layer_imports():
    # The package owns one name (issue 27): the layers are ``rcsim.models`` ... and nothing
    # imports a top-level ``models``, ``spacecraft``, ``lookup`` or ``analysis`` -- which would
    # be another project's package, or a user's ``analysis.py`` in the working directory.
    bad = sorted(
        {
            f"{p.relative_to(ROOT)}: {i}"
            for folder in ["rcsim", "tests", "benchmarks"]
            for p in (ROOT / folder).rglob("*.py")
            if "__pycache__" not in p.parts
            for i in imports_of(p)
            if i.split(".")[0] in ("models", "spacecraft", "lookup", "analysis")
        }
    )
    assert not bad, f"imports of top-level layer names: {bad}"


@pytest.mark.parametrize(
    "case", ["upward", "analysis_layer", "must_not", "only_by", "cycle", "top"]
)
def test_the_checker_sees_violations(tmp_path, case):
    """The checker itself can fail: each kind of violation, planted in a small tree, is seen."""
    files = {
        "rcsim/models/__init__.py": '"""Bottom.\n\nMust not import: rcsim.spacecraft.\n"""\n',
        "rcsim/spacecraft/__init__.py": '"""Physics."""\n',
        "rcsim/spacecraft/a.py": "import rcsim.models\n",
        "rcsim/spacecraft/b.py": "",
        "rcsim/lookup/__init__.py": (
            '"""Controllers.\n\nOnly imported by: rcsim.analysis.apps.\n"""\n'
        ),
        "rcsim/analysis/__init__.py": "",
        "rcsim/analysis/engine/__init__.py": "",
        "rcsim/analysis/results/__init__.py": "",
        "rcsim/analysis/apps/__init__.py": "",
        "rcsim/__init__.py": "",
    }
    planted = {
        "upward": ("rcsim/models/x.py", "def f():\n    from rcsim.spacecraft import a\n"),
        "analysis_layer": ("rcsim/analysis/engine/x.py", "from rcsim.analysis.apps import y\n"),
        "must_not": ("rcsim/models/x.py", "import rcsim.models\n"),  # allowed...
        "only_by": ("rcsim/analysis/engine/x.py", "import rcsim.lookup\n"),
        "cycle": ("rcsim/spacecraft/b.py", "from rcsim.spacecraft import a\n"),
        "top": ("rcsim/lookup/x.py", "import rcsim\n"),
    }
    files["rcsim/analysis/apps/y.py"] = ""
    if case == "must_not":  # ...but a stated rule forbids spacecraft from models' subtree
        files["rcsim/models/__init__.py"] = '"""Bottom.\n\nMust not import: rcsim.models.x.\n"""\n'
        files["rcsim/models/y.py"] = "from rcsim.models import x\n"
    if case == "cycle":
        files["rcsim/spacecraft/a.py"] = "from rcsim.spacecraft import b\n"
    path, text = planted[case]
    files[path] = text
    for name, content in files.items():
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_text(content)
    assert violations(tmp_path), f"the {case} violation went unseen"
