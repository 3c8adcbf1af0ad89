"""Vehicle models (MJCF) and the paper's reference tables, shipped as package data.

Owns: ``models/vehicle/vehicle.xml`` (the 16-jet spacecraft), ``models/data/*.csv`` (Gambone
Tables 1-7 with their SOURCES note) and the loaders that validate them (:mod:`models.tables`).
Must not import ``spacecraft``, ``lookup`` or ``analysis``: everything else builds on this layer.
"""
from __future__ import annotations

from importlib.resources import as_file, files
from pathlib import Path


def vehicle_xml() -> Path:
    """Path of the packaged vehicle MJCF (``models/vehicle/vehicle.xml``)."""
    with as_file(files("rcsim.models") / "vehicle" / "vehicle.xml") as path:
        return Path(path)
