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


def test_a_users_modules_named_like_the_layers_change_nothing(tmp_path):
    # Issue 27: the package owns its namespace.  A user's analysis.py, models.py, lookup.py
    # and spacecraft.py beside their script (the working directory comes first on sys.path)
    # are theirs, and rcsim's layers are still rcsim's.
    for name in ("analysis", "models", "lookup", "spacecraft"):
        (tmp_path / f"{name}.py").write_text("raise RuntimeError('the user module was imported')\n")
    probe = subprocess.run(
        [
            sys.executable,
            "-c",
            "import rcsim, rcsim.models.tables as t; rcsim.fly; "
            "print(len(t.load_rate_cases().case))",
        ],
        capture_output=True,
        text=True,
        cwd=tmp_path,
    )
    assert probe.returncode == 0, probe.stderr
    assert probe.stdout.strip() == "26"  # Table 3's rate cases, read through rcsim.models
    command = subprocess.run(
        [sys.executable, "-m", "rcsim", "vehicle", "check", "paper", "--no-pairs"],
        capture_output=True,
        text=True,
        cwd=tmp_path,
    )
    assert command.returncode == 0, command.stderr
