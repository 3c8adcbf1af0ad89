"""Fixtures shared across test packages, and the suite-wide Hypothesis profile.

Hypothesis runs derandomized everywhere (CI must be reproducible): the profile below is
registered and loaded here, before any test module is imported, so every ``@settings(...)`` in
the suite inherits ``derandomize=True`` and ``database=None`` (no example database: a run never
depends on what an earlier run on the same machine found).  A test's own ``@settings`` may
change ``max_examples`` or ``deadline``, never these two (``tests/test_packaging.py`` checks).

Browser tests take the ``chromium`` fixture: the path of headless Chromium, or a skip that says
why it is missing (``make test`` installs the Debian package when it can).
"""

import os
import shutil
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import mujoco
import numpy as np
import pytest
from hypothesis import settings

from rcsim.models.tables import PAPER_CYCLE_S, load_mass_properties
from rcsim.spacecraft.vehicle import Vehicle, build_model, load_vehicle

HYPOTHESIS_PROFILE = "rcsim-derandomized"
settings.register_profile(HYPOTHESIS_PROFILE, derandomize=True, database=None)
settings.load_profile(HYPOTHESIS_PROFILE)


@pytest.fixture(scope="module")
def model() -> mujoco.MjModel:
    """The paper's vehicle model (``paper.toml`` compiled afresh, so a test may change it) at
    its default physics settings."""
    return build_model(load_vehicle("paper"))


@pytest.fixture(scope="session")
def paper() -> Vehicle:
    """The paper's vehicle (``paper.toml``, its profile: the paper's 40 ms cycle ...)."""
    vehicle = Vehicle.load()
    assert vehicle.control.cycle_s == PAPER_CYCLE_S  # the profile is the paper's
    return vehicle


@pytest.fixture(scope="module")
def table1():
    """Gambone Table 1 mass properties (SI)."""
    return load_mass_properties()


@pytest.fixture(scope="session")
def unsorted_vehicle(tmp_path_factory) -> SimpleNamespace:
    """A vehicle file whose moments are not in descending x, y, z order and whose tensor has
    products (issue 18, "your own vehicle"): canted16.toml with Table 1's moments about other
    axes (Ixx the smallest) and products, so that MuJoCo's principal moments (descending) are
    neither in x, y, z order nor along B; its jets, propellant and dispersions are canted16's.

    Returns ``path`` and ``tensor_B``, the tensor the file states (3, 3) [kg m^2], written out
    here from the numbers put in the file (the tests' oracle, not the schema's parse).
    """
    from rcsim.spacecraft.vehicle import resolve_vehicle

    moments, products = (2457.06, 3583.09, 3160.22), (-60.0, 45.0, 30.0)
    text = resolve_vehicle("canted16").read_text()
    old = "inertia_kg_m2 = [3583.09, 3160.22, 2457.06]\nproducts_kg_m2 = [-25.0, 40.0, -15.0]"
    assert old in text
    new = f"inertia_kg_m2 = {list(moments)}\nproducts_kg_m2 = {list(products)}"
    path = tmp_path_factory.mktemp("unsorted") / "unsorted.toml"
    path.write_text(text.replace(old, new))
    (ixx, iyy, izz), (ixy, ixz, iyz) = moments, products
    tensor = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
    return SimpleNamespace(path=path, tensor_B=tensor)


@pytest.fixture(scope="session")
def chromium() -> str:
    """Path of the Chromium executable for headless browser tests; skips when there is none."""
    for name in ("chromium", "chromium-browser"):
        path = shutil.which(name)
        if path:
            return path
    pytest.skip(
        "headless Chromium not found on PATH: `make test` installs the Debian package "
        "`chromium` when run as root with apt-get; otherwise install it by hand"
    )


CHROMIUM_FLAGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
)


@pytest.fixture
def render_page(chromium, tmp_path):
    """``render_page(page, screenshot=None)``: load ``page`` (an HTML file) in headless
    Chromium and return the DOM after its scripts ran; with ``screenshot`` (a PNG path), also
    take a 1280 px wide screenshot (look at it by hand when a report changes)."""
    import subprocess

    flags = [*CHROMIUM_FLAGS, f"--user-data-dir={tmp_path / 'chromium-profile'}"]

    def render(page, screenshot=None) -> str:
        url = page.as_uri()
        dom = subprocess.run(
            [chromium, *flags, "--dump-dom", url], capture_output=True, text=True, timeout=120
        ).stdout
        if screenshot is not None:
            subprocess.run(
                [chromium, *flags, "--window-size=1280,2000", f"--screenshot={screenshot}", url],
                capture_output=True,
                timeout=120,
            )
        return dom

    return render


class _PageText:
    """What a reader sees of a report page: its visible text (no ``<nav>``, hidden in print;
    no script, style or title) and its tables, each as (caption, rows of cell texts) with the
    header row first."""

    SKIP = frozenset({"head", "script", "style", "title", "nav"})

    def __init__(self, page: str):
        from html.parser import HTMLParser

        text: list = []
        tables: list = []
        skip = [0]
        cell: list | None = None
        caption: list | None = None

        class Parser(HTMLParser):
            def handle_starttag(self, tag, attrs):
                nonlocal cell, caption
                if tag in _PageText.SKIP:
                    skip[0] += 1
                elif tag == "table":
                    tables.append(["", []])
                elif tag == "caption":
                    caption = []
                elif tag == "tr":
                    tables[-1][1].append([])
                elif tag in ("td", "th"):
                    cell = []

            def handle_endtag(self, tag):
                nonlocal cell, caption
                if tag in _PageText.SKIP:
                    skip[0] -= 1
                elif tag == "caption" and caption is not None:
                    tables[-1][0] = "".join(caption)
                    caption = None
                elif tag in ("td", "th") and cell is not None:
                    tables[-1][1][-1].append("".join(cell))
                    cell = None

            def handle_data(self, data):
                if skip[0]:
                    return
                text.append(data)
                for part in (cell, caption):
                    if part is not None:
                        part.append(data)

        Parser().feed(page)
        self.text = " ".join(text)
        self.tables = [(cap, rows) for cap, rows in tables]


@pytest.fixture
def print_report(chromium, tmp_path):
    """``print_report(page) -> (pdf, captions, problems)``: print ``page`` (an HTML file) to PDF
    in headless Chromium, as a browser's Print does (its ``@media print`` styles, no header or
    footer line), read the PDF's text back with poppler's ``pdftotext -raw`` (content order,
    no de-hyphenation) and say what did not make it to paper:

    * every visible character of the page (counted, whitespace aside) must be in the PDF --
      text cut at the page edge or hidden in a scrolled box is missing from it;
    * every row of every table, header row included, must appear whole and in order: its
      cells' texts joined, whitespace removed (a cell may wrap), are a substring of the PDF's
      text with whitespace removed -- a column lost off the page breaks its rows.

    ``captions`` are the page's table captions (so a test knows which tables were checked).
    Turn the PDF into PNG pages with ``pdftoppm -r 60 -png PDF PREFIX`` to look at it."""
    import subprocess
    from collections import Counter

    if shutil.which("pdftotext") is None:
        pytest.skip(
            "pdftotext not found on PATH: `make test` installs the Debian package "
            "`poppler-utils` when run as root with apt-get; otherwise install it by hand"
        )
    flags = [*CHROMIUM_FLAGS, f"--user-data-dir={tmp_path / 'chromium-print-profile'}"]

    def squash(s: str) -> str:
        return "".join(s.split())

    def run(page):
        pdf = tmp_path / f"{page.stem}.pdf"
        subprocess.run(
            [chromium, *flags, "--no-pdf-header-footer", f"--print-to-pdf={pdf}", page.as_uri()],
            capture_output=True,
            timeout=120,
        )
        assert pdf.is_file() and pdf.stat().st_size > 1_000, "Chromium printed no PDF"
        text = subprocess.run(
            ["pdftotext", "-raw", "-enc", "UTF-8", str(pdf), "-"],
            capture_output=True,
            text=True,
            timeout=120,
            check=True,
        ).stdout
        seen = _PageText(page.read_text(encoding="utf-8"))
        problems = []
        lost = Counter(squash(seen.text)) - Counter(squash(text))
        if lost:
            problems.append(f"{sum(lost.values())} characters not printed: {dict(lost)}")
        flat = squash(text)
        for caption, rows in seen.tables:
            for k, row in enumerate(rows):
                if squash("".join(row)) not in flat:
                    problems.append(f"table {caption!r}, row {k} not printed whole: {row}")
        return pdf, [caption for caption, _ in seen.tables], problems

    return run


#: Appended to a copy of a page by ``screen_tables``: each table box's caption and widths.
_MEASURE_TABLES = (
    "<script>var r=[];document.querySelectorAll('.tablewrap').forEach(function(w){"
    "var c=w.querySelector('caption');r.push([c?c.textContent:'',w.scrollWidth,w.clientWidth]"
    ".join('\\t'))});var p=document.createElement('pre');p.id='table-widths';"
    "p.textContent=r.join('\\n');document.body.appendChild(p);</script>"
)


@pytest.fixture
def screen_tables(chromium, tmp_path):
    """``screen_tables(page, width=1400) -> [(caption, scroll_width, box_width), ...]``: lay
    ``page`` out in headless Chromium in a window ``width`` px wide and measure every table's
    box (a table wider than its box is cut off at the box's edge until scrolled)."""
    import re
    import subprocess

    flags = [*CHROMIUM_FLAGS, f"--user-data-dir={tmp_path / 'chromium-screen-profile'}"]

    def run(page, width: int = 1400):
        copy = tmp_path / f"{page.stem}-measured.html"
        copy.write_text(
            page.read_text(encoding="utf-8").replace("</body>", _MEASURE_TABLES + "</body>"),
            encoding="utf-8",
        )
        dom = subprocess.run(
            [chromium, *flags, f"--window-size={width},1000", "--dump-dom", copy.as_uri()],
            capture_output=True,
            text=True,
            timeout=120,
        ).stdout
        found = re.search(r"<pre id=\"table-widths\">(.*?)</pre>", dom, re.S)
        assert found, "the measuring script did not run"
        rows = [line.split("\t") for line in found.group(1).splitlines() if line]
        return [(cap, int(sw), int(cw)) for cap, sw, cw in rows]

    return run


C_EXAMPLES = Path(__file__).resolve().parents[1] / "examples" / "c_fsw"


@pytest.fixture(scope="session")
def c_build():
    """``build(source, out) -> out``: a C flight-software source built as a user builds it
    (``sh examples/c_fsw/build.sh SOURCE OUT`` with this interpreter's rcsim); the test is
    skipped, saying why, on a machine without a C compiler."""
    if shutil.which(os.environ.get("CC", "cc")) is None:
        pytest.skip("no C compiler (cc) to build the C flight-software examples")

    def build(source: Path, out: Path) -> Path:
        subprocess.run(
            ["sh", str(C_EXAMPLES / "build.sh"), str(source), str(out)],
            check=True, capture_output=True, env={**os.environ, "PYTHON": sys.executable},
        )  # fmt: skip
        return out

    return build
