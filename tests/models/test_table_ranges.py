"""Tests for rcsim.models.tables beyond structure: physical ranges, tables by name, the BOM,
the packaged vehicle path, and the package's shape (small modules, one control-cycle constant).

Oracles: the paper's text (Gambone, *Pattern Recognition Control Design*, section II: 0.3 deg/s
total rate command per case, 40 ms control cycle) and its Tables 6/7 (longest firing 0.52 s);
the exact factor 180/pi between deg/s and rad/s; the ranges' written reasons in
``rcsim.models.tables.constants`` (restated below, not imported, where the test needs a number).
"""

from __future__ import annotations

import ast
import csv
import io
import math
import zipfile
from importlib.resources import files
from pathlib import Path

import numpy as np
import pytest

from rcsim.models import tables
from rcsim.models.errors import InputError

ROOT = Path(__file__).resolve().parents[2]
DATA = files("rcsim.models") / "data"
DEG_PER_RAD = 180.0 / math.pi  # rad/s written under a deg/s header is this much too small
# Ranges as the brief and constants.py state them: total rate within a factor of ten of the
# paper's 0.3 deg/s; firing times at most 5 s (about ten times the paper's longest, 0.52 s).
RATE_RANGE_DEG_S = (0.03, 3.0)
MAX_FIRING_S = 5.0


# ------------------------------------------------------------------------------------ helpers
def _raises(loader, *args, **kwargs) -> str:
    with pytest.raises(InputError) as info:
        loader(*args, **kwargs)
    msg = str(info.value)
    assert "\n" not in msg, "InputError messages are one line (the CLI prints them as-is)"
    return msg


def _rows(path) -> list[list[str]]:
    """A CSV file (a Path or a packaged resource) as rows of strings."""
    return list(csv.reader(io.StringIO(path.read_text(encoding="utf-8"))))


def _write(path: Path, rows: list[list[str]], *, bom: bool = False) -> Path:
    with open(path, "w", encoding="utf-8-sig" if bom else "utf-8", newline="") as fh:
        csv.writer(fh, lineterminator="\n").writerows(rows)
    return path


def _rcsim_table(tmp_path: Path, rate_factor: float = 1.0, name: str = "lookup.csv") -> Path:
    """Table 7 in the rcsim layout, every rate multiplied by ``rate_factor``."""
    path = tables.load_lookup_table(which="table7").to_csv(tmp_path / name)
    rows = _rows(path)
    rate_cols = [rows[0].index(c) for c in tables.RATE_COLUMNS]
    for r in rows[1:]:
        for c in rate_cols:
            r[c] = repr(float(r[c]) * rate_factor)
    return _write(path, rows)


def _paper_table_with_pair_time(
    tmp_path: Path, case: int, jets: tuple[str, str], value: str
) -> Path:
    """Table 6 (paper layout) with both jets of a pair set to ``value`` in ``case``: the pair
    stays equal and the jets stay the designed ones, so only the range can object."""
    rows = _rows(DATA / "table6_lookup_original.csv")
    row = next(r for r in rows[1:] if r[0] == str(case))
    for jet in jets:
        assert float(row[rows[0].index(jet)]) > 0, "pick a pair that fires in this case"
        row[rows[0].index(jet)] = value
    return _write(tmp_path / "table6_edited.csv", rows)


# ------------------------------------------------------------------------- rates: wrong units
def test_rcsim_table_in_rad_s_is_refused(tmp_path):
    """A well-formed table whose rates are in rad/s (57.3x too small) is self-consistent --
    one common total -- so only the physical range can catch it."""
    path = _rcsim_table(tmp_path, 1.0 / DEG_PER_RAD)
    msg = _raises(tables.load_lookup_table, path)
    # Case 1 is (-,-,-) at 0.3/sqrt(3) deg/s per axis; it sorts first, so it is reported.
    assert str(path) in msg and "row 1 (case 1)" in msg and "'roll_deg_s'" in msg, msg
    cell = _rows(path)[1][1]  # case 1, roll_deg_s: -0.1732 deg/s / 57.3 = -0.00302
    assert f"(got {float(cell)!r})" in msg and float(cell) == pytest.approx(-0.003023, rel=1e-3)
    assert "0.03..3 deg/s" in msg and "rad/s" in msg and "57.3x" in msg, msg


def test_rcsim_table_in_deg_s_read_as_rad_s_is_refused(tmp_path):
    path = _rcsim_table(tmp_path, DEG_PER_RAD)
    msg = _raises(tables.load_lookup_table, path)
    assert str(path) in msg and "(case 1)" in msg and "'roll_deg_s'" in msg, msg
    assert "0.03..3 deg/s" in msg and "larger" in msg, msg


@pytest.mark.parametrize("factor", [0.1 * 1.001, 0.2, 5.0, 10.0 * 0.999])
def test_rate_range_admits_tables_for_other_rate_commands(tmp_path, factor):
    """Inside the factor-of-ten band a table loads unchanged (0.1% inside the ends, so the
    float noise of the scaled sqrt(3) components cannot decide the test)."""
    lt = tables.load_lookup_table(_rcsim_table(tmp_path, factor))
    ref = tables.load_lookup_table(which="table7")
    np.testing.assert_allclose(lt.rate_cmd, ref.rate_cmd * factor, rtol=1e-14, atol=0)
    np.testing.assert_array_equal(lt.firing_time_s, ref.firing_time_s)


@pytest.mark.parametrize("factor", [0.1 / 1.001, 10.0 * 1.001])
def test_rate_range_ends_are_where_documented(tmp_path, factor):
    total = 0.3 * factor
    assert not RATE_RANGE_DEG_S[0] <= total <= RATE_RANGE_DEG_S[1]
    assert "physical range" in _raises(tables.load_lookup_table, _rcsim_table(tmp_path, factor))


def test_rate_cases_in_rad_s_are_refused_with_or_without_a_total(tmp_path):
    rows = _rows(DATA / "table3_rate_cases.csv")
    for r in rows[1:]:
        r[1:] = [repr(float(v) / DEG_PER_RAD) for v in r[1:]]
    path = _write(tmp_path / "table3_rad.csv", rows)
    for total in (0.3, None):
        msg = _raises(tables.load_rate_cases, path, total_rate_deg_s=total)
        assert str(path) in msg and "row 1 (case 1)" in msg and "'roll_deg_s'" in msg, msg
        assert "outside the physical range 0.03..3 deg/s" in msg, msg


# ------------------------------------------------------------------ firing times: the horizon
@pytest.mark.parametrize("value", ["1e6", "520", "5.04"])
def test_firing_time_beyond_the_horizon_is_refused(tmp_path, value):
    """1e6 s (the issue's runaway), 520 (Table 6's 0.52 s written in ms) and 5.04 s (one
    cycle past the bound) are all whole 40 ms cycles and equal within the pair: only the
    range refuses them.  Case 5 = (-,0,0) fires roll jets 1 and 3 (paper Table 6)."""
    path = _paper_table_with_pair_time(tmp_path, 5, ("jet_01", "jet_03"), value)
    msg = _raises(tables.load_lookup_table, path)
    assert str(path) in msg and "row 5 (case 5)" in msg and "'jet_01'" in msg, msg
    assert f"(got {float(value)!r})" in msg and "0..5 s" in msg, msg


def test_firing_time_at_the_bound_loads(tmp_path):
    path = _paper_table_with_pair_time(tmp_path, 5, ("jet_01", "jet_03"), repr(MAX_FIRING_S))
    lt = tables.load_lookup_table(path)
    assert lt.firing_time_s[4, 0] == lt.firing_time_s[4, 2] == MAX_FIRING_S


def test_firing_time_bound_can_be_lifted_explicitly(tmp_path):
    # A stress study may want the runaway table on purpose; it has to say so.
    path = _paper_table_with_pair_time(tmp_path, 5, ("jet_01", "jet_03"), "1e6")
    lt = tables.load_lookup_table(path, max_firing_time_s=None)
    assert lt.firing_time_s[4, 0] == 1e6


def test_check_consistency_refuses_meaningless_limits():
    lt = tables.load_lookup_table()
    jmap = tables.load_jet_map()
    for kwargs in ({"cycle_s": 0.0}, {"max_firing_time_s": -1.0}, {"cycle_s": math.nan}):
        msg = _raises(
            tables.check_consistency, lt.case, lt.rate_cmd, lt.firing_time_s, jmap, **kwargs
        )
        assert next(iter(kwargs)) in msg, msg


def test_shipped_tables_are_inside_the_ranges():
    # The packaged paper tables and rcsim/lookup/data/generated_table.csv must keep loading.
    generated = ROOT / "rcsim" / "lookup" / "data" / "generated_table.csv"
    for lt in (
        tables.load_lookup_table("table6"),
        tables.load_lookup_table("table7"),
        tables.load_lookup_table(generated),
    ):
        assert 0 < lt.firing_time_s.max() <= MAX_FIRING_S
        total = np.linalg.norm(np.rad2deg(lt.rate_cmd), axis=1)
        assert np.all((RATE_RANGE_DEG_S[0] <= total) & (total <= RATE_RANGE_DEG_S[1]))


# --------------------------------------------------------------------------- tables by name
@pytest.mark.parametrize("name", ["table6", "table7"])
def test_paper_tables_load_by_name(name):
    by_name = tables.load_lookup_table(name)
    by_path_obj = tables.load_lookup_table(Path(name))
    ref = tables.load_lookup_table(which=name)
    for lt in (by_name, by_path_obj):
        np.testing.assert_array_equal(lt.firing_time_s, ref.firing_time_s)
        np.testing.assert_array_equal(lt.rate_cmd, ref.rate_cmd)
        assert lt.source == ref.source  # the installed package's own copy
    assert ref.source.endswith(tables.PAPER_LOOKUP_TABLES[name])


def test_name_and_local_file_of_that_name_is_ambiguous(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    local = _rcsim_table(tmp_path, name="table6")
    msg = _raises(tables.load_lookup_table, "table6")
    assert "ambiguous" in msg and "./table6" in msg, msg
    lt = tables.load_lookup_table("./table6")  # the explicit path reads the local file
    assert lt.source == "table6" and local.is_file()


def test_unknown_name_is_a_missing_file(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    msg = _raises(tables.load_lookup_table, "table8")
    assert msg == "table8: file not found"


# ----------------------------------------------------------------------------------- the BOM
@pytest.mark.parametrize(
    "loader, name",
    [
        (tables.load_rate_cases, "table3_rate_cases.csv"),
        (tables.load_lookup_table, "table6_lookup_original.csv"),
        (tables.load_mass_properties, "table1_mass_properties.csv"),
    ],
)
def test_utf8_bom_is_accepted(tmp_path, loader, name):
    """Spreadsheet programs export CSV with a UTF-8 byte-order mark; without utf-8-sig the
    first header would read '\\ufeffcase' and the file would be refused."""
    path = _write(tmp_path / name, _rows(DATA / name), bom=True)
    assert path.read_bytes()[:3] == b"\xef\xbb\xbf"
    with_bom, plain = loader(path), loader(_write(tmp_path / f"plain_{name}", _rows(DATA / name)))
    for field in vars(plain):
        a, b = getattr(with_bom, field), getattr(plain, field)
        if field != "source":
            np.testing.assert_array_equal(a, b, err_msg=field)


# ------------------------------------------------------------------ packaged MJCF by path
def test_packaged_mjcf_from_a_zip_install_stays_valid(tmp_path, monkeypatch):
    """MuJoCo needs a real path; from a zip archive ``as_file`` extracts to a temporary file,
    which must outlive the call (returning the path after the context closed hands back a
    deleted file).  Simulate a zip install of the DAI model's folder."""
    from rcsim.models import dai

    xml = dai.dai_xml().read_bytes()
    archive = tmp_path / "pkg.zip"
    with zipfile.ZipFile(archive, "w") as zf:
        zf.writestr("dai_spacecraft.xml", xml)
    monkeypatch.setattr(dai, "files", lambda package: zipfile.Path(archive))
    path = dai._resource("dai_spacecraft.xml")
    assert not str(path).startswith(str(tmp_path)), "an extracted copy, not the archive"
    assert path.is_file() and path.read_bytes() == xml


# ------------------------------------------------------------------------- the package shape
def test_table_modules_are_small():
    sizes = {
        p.name: len(p.read_text().splitlines())
        for p in (ROOT / "rcsim" / "models" / "tables").glob("*.py")
    }
    assert {"constants.py", "schema.py", "consistency.py", "lookup_tables.py"} <= set(sizes)
    assert not (ROOT / "rcsim" / "models" / "tables.py").exists(), "the old monolith is gone"
    big = {name: n for name, n in sizes.items() if n >= 400}
    assert not big, f"modules over the ~400-line guideline: {big}"


def test_control_cycle_is_defined_once():
    """PAPER_CYCLE_S (paper section II: 40 ms) is assigned in exactly one module."""
    defs = []
    for layer in ("models", "spacecraft", "lookup", "analysis"):
        for path in (ROOT / "rcsim" / layer).rglob("*.py"):
            for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
                targets = (
                    node.targets
                    if isinstance(node, ast.Assign)
                    else [node.target]
                    if isinstance(node, ast.AnnAssign)
                    else []
                )
                if any(isinstance(t, ast.Name) and t.id == "PAPER_CYCLE_S" for t in targets):
                    defs.append(str(path.relative_to(ROOT)))
    assert defs == ["rcsim/models/tables/constants.py"]
    assert tables.PAPER_CYCLE_S == 0.040


def test_public_names_are_re_exported():
    # Everything other packages and tests import from rcsim.models.tables (grep of the repo).
    for name in (
        "AXES",
        "PAPER_CYCLE_S",
        "N_CASES",
        "N_JETS",
        "PAPER_TOTAL_RATE_DEG_S",
        "RATE_RTOL",
        "RATE_COLUMNS",
        "Correction",
        "LookupInputs",
        "LookupTable",
        "MassProperties",
        "RateCases",
        "check_consistency",
        "load_dispersions",
        "load_jet_map",
        "load_lookup_inputs",
        "load_lookup_table",
        "load_mass_properties",
        "load_rate_cases",
        "paper_corrections",
        "sign_patterns",
    ):
        assert name in tables.__all__ and hasattr(tables, name), name
    doc = tables.__doc__
    assert "Must not import" in doc and "spacecraft" in doc and "analysis" in doc
