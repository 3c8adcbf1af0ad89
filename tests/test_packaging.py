"""Packaging and claims: what pyproject.toml says is what the tree holds and the code needs.

Oracles: the tree itself (every folder with an ``__init__.py``, every data file beside the
code) and the code's own imports; ``.ci/min-versions.txt`` for the lowest versions, which
``make test-min`` installs and runs the suite on (so each lower bound is a tested claim, and
this file checks that the pins and the bounds say the same thing).  Also the suite's own
honesty rules that are cheap to check statically: Hypothesis runs derandomized with no example
database (CI is reproducible), and no test skips because one of our own modules fails to import.
"""
import ast
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
PACKAGE_DIR = SETUPTOOLS["package-dir"]  # "rcsim.models" -> "models", ...
LISTED = SETUPTOOLS["packages"]
MIN_PINS = ROOT / ".ci" / "min-versions.txt"


def _folder(package: str) -> Path:
    """Source folder of a dotted package name through ``package-dir``."""
    for prefix in sorted(PACKAGE_DIR, key=len, reverse=True):
        if package == prefix or package.startswith(prefix + "."):
            rest = package[len(prefix):].lstrip(".")
            return ROOT / PACKAGE_DIR[prefix] / Path(*rest.split(".") if rest else ())
    raise AssertionError(f"pyproject.toml lists {package!r}, which no package-dir entry maps")


def _package_of(folder: Path) -> str:
    """Dotted name of a source folder (the inverse of :func:`_folder`)."""
    for prefix, top in PACKAGE_DIR.items():
        top_path = ROOT / top
        if folder == top_path or top_path in folder.parents:
            return ".".join([prefix, *folder.relative_to(top_path).parts])
    raise AssertionError(f"{folder} is outside the package folders")


def _source_files(pattern: str) -> list[Path]:
    return sorted(p for top in PACKAGE_DIR.values() for p in (ROOT / top).rglob(pattern)
                  if "__pycache__" not in p.parts)


# --------------------------------------------------------------------------- packages --
def test_every_package_folder_is_listed():
    # A folder with an __init__.py that is not listed is left out of a (non-editable) install:
    # its modules import in the source tree and fail once installed.
    found = {_package_of(p.parent) for p in _source_files("__init__.py")}
    missing = sorted(found - set(LISTED))
    assert not missing, f"add to [tool.setuptools] packages in pyproject.toml: {missing}"


def test_every_listed_package_exists():
    # A listed package without a folder (and __init__.py) breaks `pip install`.
    absent = [p for p in LISTED if not (_folder(p) / "__init__.py").is_file()]
    assert not absent, f"listed in pyproject.toml but no <folder>/__init__.py: {absent}"


def test_every_python_module_is_inside_a_listed_package():
    # A module in a folder without __init__.py imports from the source tree (namespace
    # package) but is not installed: the listed packages must cover every .py file.
    listed_folders = {_folder(p) for p in LISTED}
    orphans = [str(p.relative_to(ROOT)) for p in _source_files("*.py")
               if p.parent not in listed_folders]
    assert not orphans, f"modules outside any listed package (add an __init__.py): {orphans}"


def test_package_data_globs_cover_every_data_file():
    # Oracle: setuptools matches package-data globs relative to the package folder with
    # recursive '**' (glob.glob(recursive=True)); pathlib's glob does the same.  Every file
    # beside the code that is not Python (tables, MJCF, READMEs, templates) must ship.
    package_data = SETUPTOOLS.get("package-data", {})
    data_files = [p for p in _source_files("*") if p.is_file() and p.suffix not in (".py", ".pyc")]
    assert data_files, "no data files found: the tables and MJCF should be here"
    shipped = set()
    for package, globs in package_data.items():
        for pattern in globs:
            shipped.update(_folder(package).glob(pattern))
    unshipped = [str(p.relative_to(ROOT)) for p in data_files if p not in shipped]
    assert not unshipped, f"data files no package-data glob covers: {unshipped}"


def test_packaged_data_the_code_loads_is_present():
    # The loaders find these through importlib.resources; each is read at import or first use.
    from importlib.resources import files

    for package, name in [("rcsim.models", "vehicle/vehicle.xml"),
                          ("rcsim.models", "data/table1_mass_properties.csv"),
                          ("rcsim.lookup", "data/generated_table.csv")]:
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


def test_requires_python_covers_the_standard_library_the_code_imports():
    # Oracle: the Python docs' "New in version" notes: tomllib is 3.11+.  Whatever else is
    # added here must come with its version.
    newer_stdlib = {"tomllib": Version("3.11")}
    claimed = _lower_bound(SpecifierSet(PYPROJECT["project"]["requires-python"]))
    needed = {}
    for path in _source_files("*.py"):
        for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import) else
                     [node.module] if isinstance(node, ast.ImportFrom) and node.module else [])
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
                    if kw.arg == "derandomize" and not (isinstance(kw.value, ast.Constant)
                                                        and kw.value.value is True):
                        bad.append(f"{path.relative_to(ROOT)}:{node.lineno} derandomize")
                    if kw.arg == "database" and not (isinstance(kw.value, ast.Constant)
                                                     and kw.value.value is None):
                        bad.append(f"{path.relative_to(ROOT)}:{node.lineno} database")
    assert not bad, f"Hypothesis settings that make CI irreproducible: {bad}"


def test_no_importorskip_of_our_own_modules():
    # A broken import of rcsim must fail the suite, not skip the tests that would show it.
    bad = []
    for path in _test_sources():
        for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
            if (isinstance(node, ast.Call) and ast.unparse(node.func).endswith("importorskip")
                    and node.args and isinstance(node.args[0], ast.Constant)
                    and str(node.args[0].value).split(".")[0] in ("rcsim", *PACKAGE_DIR.values())):
                bad.append(f"{path.relative_to(ROOT)}:{node.lineno} {node.args[0].value}")
    assert not bad, f"importorskip on rcsim's own modules: {bad}"
