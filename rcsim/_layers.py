"""Refuse to run on another package's ``models``, ``spacecraft``, ``lookup`` or ``analysis``.

rcsim's layers are top-level packages (the tree is the package layout, issue 15).  A module or
package of the same name earlier on ``sys.path`` -- typically a ``models.py`` or an
``analysis/`` package in the working directory of ``python -m rcsim`` or a notebook -- would be
imported in its place, and fail far from the cause.  This check names it instead.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

LAYERS = ("models", "spacecraft", "lookup", "analysis")


def check_layers() -> None:
    """Raise ImportError naming the first layer that resolves outside rcsim's installation."""
    home = Path(__file__).resolve().parent.parent
    for name in LAYERS:
        spec = importlib.util.find_spec(name)
        origin = Path(spec.origin).resolve() if spec is not None and spec.origin else None
        if origin is None or origin != home / name / "__init__.py":
            found = origin if origin is not None else "a namespace package"
            raise ImportError(
                f"rcsim: import {name!r} finds {found}, not rcsim's {home / name}; a module or "
                f"package named {name!r} earlier on sys.path (often the working directory) "
                "shadows it: rename it, or run from another directory"
            )
