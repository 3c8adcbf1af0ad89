"""Fixtures shared across test packages, and the suite-wide Hypothesis profile.

Hypothesis runs derandomized everywhere (CI must be reproducible): the profile below is
registered and loaded here, before any test module is imported, so every ``@settings(...)`` in
the suite inherits ``derandomize=True`` and ``database=None`` (no example database: a run never
depends on what an earlier run on the same machine found).  A test's own ``@settings`` may
change ``max_examples`` or ``deadline``, never these two (``tests/test_packaging.py`` checks).

Browser tests take the ``chromium`` fixture: the path of headless Chromium, or a skip that says
why it is missing (``make test`` installs the Debian package when it can).
"""

import shutil

import mujoco
import pytest
from hypothesis import settings

from models.tables import load_mass_properties
from spacecraft.vehicle import load_model

HYPOTHESIS_PROFILE = "rcsim-derandomized"
settings.register_profile(HYPOTHESIS_PROFILE, derandomize=True, database=None)
settings.load_profile(HYPOTHESIS_PROFILE)


@pytest.fixture(scope="module")
def model() -> mujoco.MjModel:
    """The packaged vehicle at its default physics settings."""
    return load_model()


@pytest.fixture(scope="module")
def table1():
    """Gambone Table 1 mass properties (SI)."""
    return load_mass_properties()


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
