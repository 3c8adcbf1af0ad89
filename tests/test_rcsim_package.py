"""The ``rcsim`` package on top: its version, ``python -m rcsim``, its public names and help.

Oracles: the installed distribution's metadata (``importlib.metadata``) for the version; the
package's own ``__all__`` for the public API (each name resolves, is documented, and is listed
in the package docstring that ``help(rcsim)`` shows).
"""

import importlib.metadata
import subprocess
import sys

import pytest

import rcsim


def test_version_is_the_installed_one_and_the_cli_prints_it():
    assert rcsim.__version__ == importlib.metadata.version("rcsim")
    out = subprocess.run(
        [sys.executable, "-m", "rcsim", "--version"], capture_output=True, text=True, check=True
    ).stdout
    assert out.strip() == f"rcsim {rcsim.__version__}"


@pytest.mark.parametrize("name", [n for n in rcsim.__all__ if n != "__version__"])
def test_every_public_name_resolves_and_is_documented(name):
    value = getattr(rcsim, name)
    assert (value.__doc__ or "").strip(), f"rcsim.{name} has no docstring for help()"
    assert name in rcsim.__doc__, f"help(rcsim) does not list {name}"


def test_an_unknown_name_is_an_attribute_error():
    with pytest.raises(AttributeError, match="no_such_thing"):
        rcsim.no_such_thing  # noqa: B018


def test_a_shadowing_module_in_the_working_directory_is_named(tmp_path):
    # A user's models.py next to their notebook would be imported instead of rcsim's layer.
    (tmp_path / "models.py").write_text("x = 1\n")
    run = subprocess.run(
        [sys.executable, "-m", "rcsim", "--help"], capture_output=True, text=True, cwd=tmp_path
    )
    assert run.returncode == 2
    assert run.stderr.count("\n") == 1 and "models.py" in run.stderr and "shadows" in run.stderr
    probe = subprocess.run(
        [sys.executable, "-c", "import rcsim; rcsim.fly"],
        capture_output=True,
        text=True,
        cwd=tmp_path,
    )
    assert probe.returncode != 0 and "shadows it" in probe.stderr
