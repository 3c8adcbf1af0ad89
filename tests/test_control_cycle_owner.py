"""The control cycle has one owner, the vehicle's flight-software profile (issue 27).

Read from the source (AST), so the claim is about the code as written: no function or class
field in rcsim gives a control cycle a default (a controller, the valve model or the flight
loop built without the vehicle's cycle would silently fly the paper's), and no literal 0.04
stands in the code: the paper's 40 ms is written once, ``PAPER_CYCLE_S`` in
``rcsim/models/tables/constants.py``, and ``paper.toml``'s ``[control] cycle_s``.

Two exemptions, each for a reason: the paper's data layer (``rcsim/models/tables/``) checks a
table's firing times against the cycle the table format was designed for, the paper's, unless
told another (it flies nothing); and two literals that are not a cycle, named below.
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1] / "rcsim"


def _sources():
    return sorted(p for p in ROOT.rglob("*.py") if "__pycache__" not in p.parts)


def _cycle_defaults(tree: ast.AST) -> list[str]:
    """Parameters and dataclass fields named ``*cycle_s`` with a default."""
    found = []
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            a = node.args
            positional = a.posonlyargs + a.args
            with_default = positional[len(positional) - len(a.defaults) :]
            kw = [arg for arg, d in zip(a.kwonlyargs, a.kw_defaults) if d is not None]
            for arg in with_default + kw:
                if arg.arg.endswith("cycle_s"):
                    found.append(f"{node.name}({arg.arg}=...) line {node.lineno}")
        if isinstance(node, ast.ClassDef):
            for item in node.body:
                if (
                    isinstance(item, ast.AnnAssign)
                    and isinstance(item.target, ast.Name)
                    and item.target.id.endswith("cycle_s")
                    and item.value is not None
                ):
                    found.append(f"{node.name}.{item.target.id} line {item.lineno}")
    return found


#: Literals equal to 0.04 that are not the control cycle: (module, the name they define).
NOT_A_CYCLE = {
    # 0.04 deg/s, the paper's failure threshold
    ("spacecraft/vehicle/definition.py", "PAPER_RATE_ERROR_DEG_S"),
    ("lookup/response_database.py", "ON_TIMES_S"),  # a 40 ms pulse among those fired
    # 0.04 deg/s, the synthetic campaigns' failure threshold
    ("analysis/results/drivers/synthetic.py", "SYNTHETIC_THRESHOLD_DEG_S"),
}


def _assigned_name(tree: ast.AST, lineno: int) -> str | None:
    for node in ast.walk(tree):
        if isinstance(node, ast.Assign) and node.lineno <= lineno <= (node.end_lineno or 0):
            target = node.targets[0]
            return target.id if isinstance(target, ast.Name) else None
    return None


def test_no_control_cycle_has_a_default():
    bad = {
        str(p.relative_to(ROOT)): hits
        for p in _sources()
        if not p.relative_to(ROOT).as_posix().startswith("models/tables/")
        and (hits := _cycle_defaults(ast.parse(p.read_text())))
    }
    assert not bad, f"cycle defaults (the profile is the one owner): {bad}"


def test_no_literal_forty_milliseconds_in_the_code():
    bad = []
    for p in _sources():
        if p.relative_to(ROOT).as_posix() == "models/tables/constants.py":
            continue
        tree = ast.parse(p.read_text())
        for node in ast.walk(tree):
            if isinstance(node, ast.Constant) and node.value in (0.04, 0.040):
                where = (p.relative_to(ROOT).as_posix(), _assigned_name(tree, node.lineno))
                if where not in NOT_A_CYCLE:
                    bad.append(f"{p.relative_to(ROOT)}:{node.lineno}")
    assert not bad, f"literal 0.04 (write the profile's cycle): {bad}"


def test_the_checker_sees_a_default(tmp_path):
    """The scan can fail: a planted default and a planted literal are seen."""
    tree = ast.parse("def f(x, cycle_s=0.04):\n    return x\n")
    assert _cycle_defaults(tree) == ["f(cycle_s=...) line 1"]
    tree = ast.parse("class P:\n    cycle_s: float = 1.0\n")
    assert _cycle_defaults(tree) == ["P.cycle_s line 2"]
