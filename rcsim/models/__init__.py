"""Vehicle models (MJCF) and the paper's reference tables, shipped as package data.

Owns: ``rcsim/models/vehicle/vehicle.xml`` (the 16-jet spacecraft), ``rcsim/models/data/*.csv``
(Gambone Tables 1-7 with their SOURCES note), the loaders that validate them and the paper's design
constants such as ``PAPER_CYCLE_S`` (:mod:`rcsim.models.tables`), the one user-error type
(:mod:`rcsim.models.errors`) and the atomic file writer (:mod:`rcsim.models.atomic`).
Everything else builds on this layer.

Must not import: rcsim.spacecraft, rcsim.lookup, rcsim.analysis, rcsim.
"""

from __future__ import annotations

import atexit
import functools
from contextlib import ExitStack
from importlib.resources import as_file, files
from pathlib import Path


@functools.cache
def vehicle_xml() -> Path:
    """Path of the packaged vehicle MJCF (``rcsim/models/vehicle/vehicle.xml``), valid for the life
    of the process.

    MuJoCo needs a real file path.  Installed from files (a wheel or an editable install) the
    resource *is* that file and is returned as is.  From a zip archive, ``as_file`` extracts it
    to a temporary file that exists only while its context is open, so the context is kept open
    until the interpreter exits (the pattern the ``importlib.resources`` documentation gives)
    instead of returning a path that is deleted on return.
    """
    resource = files("rcsim.models") / "vehicle" / "vehicle.xml"
    if isinstance(resource, Path):
        return resource
    keep = ExitStack()
    atexit.register(keep.close)
    return Path(keep.enter_context(as_file(resource)))
