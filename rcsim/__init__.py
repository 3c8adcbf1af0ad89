"""rcsim: spacecraft reaction-control simulation for RCS analysts.

The package on top owns the version, ``python -m rcsim`` and the public API; the code lives in
the four layers the tree shows, each a top-level package, with one-way imports::

    models  <-  spacecraft  <-  lookup  <-  analysis  <-  rcsim
    (MJCF,      (vehicle,       (control-   (engine: fly and write; results: read and
     tables)     physics)        lers)       judge; apps: loop, CLI, studies)

See ``docs/api.md`` for the Python API with a worked example.
"""
from __future__ import annotations

__version__ = "0.2.0"
