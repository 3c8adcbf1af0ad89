"""Packaging and claims: what pyproject.toml says is what the tree holds and the code needs.

Oracles: the tree itself (every folder with an ``__init__.py``, every data file beside the
code) and the code's own imports; ``.ci/min-versions.txt`` for the lowest versions, which
``make test-min`` installs and runs the suite on (so each lower bound is a tested claim, and
this file checks that the pins and the bounds say the same thing).  Also the suite's own
honesty rules that are cheap to check statically: Hypothesis runs derandomized with no example
database (CI is reproducible), and no test skips because one of our own modules fails to import.
"""

import ast
import os
import re
import tomllib
from pathlib import Path

import pytest
from hypothesis import settings
from packaging.requirements import Requirement
from packaging.specifiers import SpecifierSet
from packaging.version import Version

ROOT = Path(__file__).resolve().parents[1]
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())
SETUPTOOLS = PYPROJECT["tool"]["setuptools"]
FIND = SETUPTOOLS["packages"]["find"]
#: The one name the package owns, and the design card's four layers, its visible top.
PACKAGE = "rcsim"
LAYERS = ("models", "spacecraft", "lookup", "analysis")
MIN_PINS = ROOT / ".ci" / "min-versions.txt"


def _found_packages() -> set[str]:
    """What setuptools installs: its own discovery with pyproject.toml's settings."""
    from setuptools import find_namespace_packages

    return set(
        find_namespace_packages(
            where=str(ROOT / FIND["where"][0]),
            include=FIND["include"],
            exclude=FIND.get("exclude", ()),
        )
    )


def _source_files(pattern: str) -> list[Path]:
    return sorted(p for p in (ROOT / PACKAGE).rglob(pattern) if "__pycache__" not in p.parts)


def _package_of(folder: Path) -> str:
    return ".".join(folder.relative_to(ROOT).parts)


# --------------------------------------------------------------------------- packages --
def test_the_package_owns_one_name_and_the_layers_are_its_top():
    # Issue 27: ``rcsim`` is the only top-level name; the design card's four layers are its
    # visible top (rcsim/models, ...), so tools resolve every import from the folders.  "" ->
    # "." only makes the root the source root (an editable install is then one .pth entry).
    assert SETUPTOOLS.get("package-dir", {}) in ({}, {"": "."})
    found = _found_packages()
    assert {p.split(".")[0] for p in found} == {PACKAGE}, sorted(found)
    assert {f"{PACKAGE}.{layer}" for layer in LAYERS} <= found
    assert not any((ROOT / layer).exists() for layer in LAYERS), "a layer left at the root"


def test_every_python_module_is_inside_an_installed_package():
    # A module in a folder the discovery misses imports from the source tree and is absent
    # from a wheel.
    found = _found_packages()
    orphans = [
        str(p.relative_to(ROOT))
        for p in _source_files("*.py")
        if _package_of(p.parent) not in found
    ]
    assert not orphans, f"modules outside any installed package: {orphans}"


def test_every_regular_package_has_its_init():
    # A code folder without __init__.py would be a namespace package: legal, but then its
    # docstring (what it owns, what it must not import) is missing.  Only data folders may
    # lack one.
    bare = sorted(
        {
            str(p.parent.relative_to(ROOT))
            for p in _source_files("*.py")
            if not (p.parent / "__init__.py").is_file()
        }
    )
    assert not bare, f"code folders without __init__.py: {bare}"


def test_package_data_globs_cover_every_data_file():
    # Oracle: setuptools matches package-data globs relative to the package folder.  Every
    # file beside the code that is not Python (tables, MJCF, READMEs, py.typed) must ship.
    package_data = SETUPTOOLS.get("package-data", {})
    # C sources and the extensions built from them are setup.py's (next test), not data.
    data_files = [
        p
        for p in _source_files("*")
        if p.is_file() and p.suffix not in (".py", ".pyc", ".c", ".so")
    ]
    assert data_files, "no data files found: the tables and MJCF should be here"
    shipped = set()
    for package, globs in package_data.items():
        for pattern in globs:
            shipped.update((ROOT / Path(*package.split("."))).glob(pattern))
    unshipped = [str(p.relative_to(ROOT)) for p in data_files if p not in shipped]
    assert not unshipped, f"data files no package-data glob covers: {unshipped}"


def test_every_c_source_is_a_declared_extension():
    # A C file setup.py does not name would never be compiled; one it names must exist.
    setup_py = (ROOT / "setup.py").read_text()
    named = set(re.findall(r'"([\w/]+\.c)"', setup_py))
    present = {str(p.relative_to(ROOT)) for p in _source_files("*.c")}
    assert present == named, f"C sources {sorted(present)} against setup.py's {sorted(named)}"


def test_the_package_is_typed():
    # PEP 561: a type checker uses an installed package's annotations only beside py.typed
    # at the package's top (it covers the subpackages).
    assert (ROOT / PACKAGE / "py.typed").is_file()


def test_packaged_data_the_code_loads_is_present():
    # The loaders find these through importlib.resources; each is read at import or first use.
    from importlib.resources import files

    for package, name in [
        ("rcsim.models", "vehicle/paper.toml"),
        ("rcsim.models", "data/table1_mass_properties.csv"),
        ("rcsim.lookup", "data/generated_table.csv"),
    ]:
        assert (files(package) / name).is_file(), f"{package}: {name} missing"


# ------------------------------------------------------------------- version claims --
def _lower_bound(spec: SpecifierSet) -> Version:
    bounds = [Version(s.version) for s in spec if s.operator in (">=", "==", "~=")]
    assert len(bounds) == 1, f"{spec}: expected exactly one lower bound"
    return bounds[0]


def _pins() -> dict[str, Version]:
    pins = {}
    for line in MIN_PINS.read_text().splitlines():
        line = line.split("#", 1)[0].strip()
        if line:
            req = Requirement(line)
            (spec,) = list(req.specifier)
            assert spec.operator == "==", f"{MIN_PINS.name}: {line!r} is not an exact pin"
            pins[req.name.lower()] = Version(spec.version)
    return pins


def _claimed_requirements() -> list[Requirement]:
    project = PYPROJECT["project"]
    texts = [*project["dependencies"], *project["optional-dependencies"]["test"]]
    build = [Requirement(t) for t in PYPROJECT["build-system"]["requires"]]
    # Build requirements without a bound (wheel) claim nothing; everything else must.
    return [Requirement(t) for t in texts] + [r for r in build if r.specifier]


@pytest.mark.parametrize("req", _claimed_requirements(), ids=lambda r: r.name)
def test_min_pin_is_the_lowest_release_of_each_bound(req):
    # The pin must satisfy the claim and sit in the bound's own release series (">=1.11" is
    # tested on 1.11.x, the first 1.11 release published), so passing `make test-min` proves
    # the bound, not something higher.
    assert req.specifier, f"{req.name}: every dependency states the lowest version it needs"
    pins = _pins()
    assert req.name.lower() in pins, f"{req.name}: no pin in {MIN_PINS.name}"
    pin, bound = pins[req.name.lower()], _lower_bound(req.specifier)
    assert pin in req.specifier, f"{req.name}=={pin} does not satisfy {req.specifier}"
    n = len(bound.release)
    assert pin.release[:n] == bound.release, f"{req.name}: pin {pin} is above bound {bound}"


def test_every_pin_is_a_claimed_requirement_or_its_build_helper():
    # A stale pin (a dependency dropped from pyproject.toml) would test a claim nobody makes.
    # wheel: setuptools' build backend imports it; pinned, not claimed.
    claimed = {r.name.lower() for r in _claimed_requirements()} | {"wheel"}
    extra = sorted(set(_pins()) - claimed - {"distributed"})  # distributed: dask[distributed]
    assert not extra, f"pins for packages pyproject.toml does not require: {extra}"


def _make_pytest_command(target: str) -> list[str]:
    """The options of a Makefile target's ``python -m pytest`` command, split into words
    (quotes kept)."""
    recipe = (ROOT / "Makefile").read_text().split(f"\n{target}:", 1)[1].split("\n\n", 1)[0]
    (line,) = [line for line in recipe.splitlines() if " -m pytest" in line]
    return re.findall(r'"[^"]*"|\S+', line.split(" -m pytest", 1)[1])


def test_make_test_runs_every_test_and_test_min_leaves_out_only_the_slow_ones():
    # `make test` is the whole suite: no selection in pytest's own options nor in its command.
    # `make test-min` leaves out the tests marked `slow` and nothing else (docs/dependencies.md
    # says why those add no version coverage); the marker is registered (--strict-markers).
    selecting = {"-m", "-k", "--deselect", "--ignore", "--ignore-glob", "-x", "--maxfail"}
    ini = PYPROJECT["tool"]["pytest"]["ini_options"]
    assert not selecting & set(ini["addopts"].split()), ini["addopts"]
    assert not selecting & set(_make_pytest_command("test")), _make_pytest_command("test")
    words = _make_pytest_command("test-min")
    assert [w for w in words if w in selecting] == ["-m"]
    assert words[words.index("-m") + 1] == '"not slow"'
    assert any(m.startswith("slow:") for m in ini["markers"])


def test_requires_python_covers_the_standard_library_the_code_imports():
    # Oracle: the Python docs' "New in version" notes: tomllib is 3.11+.  Whatever else is
    # added here must come with its version.
    newer_stdlib = {"tomllib": Version("3.11")}
    claimed = _lower_bound(SpecifierSet(PYPROJECT["project"]["requires-python"]))
    needed = {}
    for path in _source_files("*.py"):
        for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
            names = (
                [a.name for a in node.names]
                if isinstance(node, ast.Import)
                else [node.module]
                if isinstance(node, ast.ImportFrom) and node.module
                else []
            )
            for name in names:
                top = name.split(".")[0]
                if top in newer_stdlib and newer_stdlib[top] > claimed:
                    where = str(path.relative_to(ROOT))
                    needed[where] = f"{top} needs Python >= {newer_stdlib[top]}"
    assert not needed, f"requires-python >= {claimed} is not true: {needed}"


# --------------------------------------------------------------------- test honesty --
def test_hypothesis_profile_is_derandomized_without_database():
    # tests/conftest.py loads the profile; every @settings in the suite inherits from it.
    assert settings.default.derandomize is True
    assert settings.default.database is None


def _test_sources():
    return sorted(p for p in (ROOT / "tests").rglob("*.py") if "__pycache__" not in p.parts)


def test_no_test_turns_hypothesis_randomness_or_database_back_on():
    bad = []
    for path in _test_sources():
        for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
            if isinstance(node, ast.Call) and ast.unparse(node.func).endswith("settings"):
                for kw in node.keywords:
                    if kw.arg == "derandomize" and not (
                        isinstance(kw.value, ast.Constant) and kw.value.value is True
                    ):
                        bad.append(f"{path.relative_to(ROOT)}:{node.lineno} derandomize")
                    if kw.arg == "database" and not (
                        isinstance(kw.value, ast.Constant) and kw.value.value is None
                    ):
                        bad.append(f"{path.relative_to(ROOT)}:{node.lineno} database")
    assert not bad, f"Hypothesis settings that make CI irreproducible: {bad}"


def test_no_importorskip_of_our_own_modules():
    # A broken import of rcsim must fail the suite, not skip the tests that would show it.
    bad = []
    for path in _test_sources():
        for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
            if (
                isinstance(node, ast.Call)
                and ast.unparse(node.func).endswith("importorskip")
                and node.args
                and isinstance(node.args[0], ast.Constant)
                and str(node.args[0].value).split(".")[0] == PACKAGE
            ):
                bad.append(f"{path.relative_to(ROOT)}:{node.lineno} {node.args[0].value}")
    assert not bad, f"importorskip on rcsim's own modules: {bad}"


# ------------------------------------------------------------------ the installed wheel --
def test_an_installed_wheel_puts_only_rcsim_into_site_packages(tmp_path):
    """Issue 27: the wheel, installed into a clean venv, adds ``rcsim`` and its dist-info and
    no other top-level name (``models``, ``analysis``... are other projects' on the package
    index).  Oracle: site-packages listed before and after the install."""
    import subprocess
    import sys
    import venv

    wheels = tmp_path / "wheels"
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--quiet", "--no-deps", "--no-build-isolation",
         "--wheel-dir", str(wheels), str(ROOT)],
        check=True, capture_output=True, timeout=600,
    )  # fmt: skip
    (wheel,) = wheels.glob("rcsim-*.whl")
    env = tmp_path / "venv"
    venv.create(env, with_pip=True)
    python = env / "bin" / "python"
    site = subprocess.run(
        [python, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
        check=True, capture_output=True, text=True,
    ).stdout.strip()  # fmt: skip
    before = set(os.listdir(site))
    subprocess.run(
        [python, "-m", "pip", "install", "--quiet", "--no-deps", "--no-index", str(wheel)],
        check=True, capture_output=True, timeout=300,
    )  # fmt: skip
    added = set(os.listdir(site)) - before
    names = {n for n in added if n != "__pycache__"}
    dist_info = {n for n in names if n.endswith(".dist-info")}
    assert names - dist_info == {"rcsim"}, sorted(names)
    assert len(dist_info) == 1 and next(iter(dist_info)).startswith("rcsim-"), sorted(names)
    version = subprocess.run(
        [python, "-c", "import rcsim; print(rcsim.__version__)"],
        check=True, capture_output=True, text=True, cwd=tmp_path,
    ).stdout.strip()  # fmt: skip
    assert version == PYPROJECT_VERSION()


def PYPROJECT_VERSION() -> str:  # noqa: N802 - reads like the constant it stands for
    import rcsim

    return rcsim.__version__
