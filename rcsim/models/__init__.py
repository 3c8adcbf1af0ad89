"""The packaged vehicles and the paper's reference tables, shipped as package data.

Owns: ``rcsim/models/vehicle/*.toml`` (the vehicle files: ``paper.toml``, Gambone's 16-jet
spacecraft, and the canted examples; read by :mod:`rcsim.spacecraft.vehicle`),
``rcsim/models/data/*.csv`` (Gambone Tables 1-7 with their SOURCES note), the loaders that
validate them and the paper's design constants such as ``PAPER_CYCLE_S``
(:mod:`rcsim.models.tables`), the one user-error type (:mod:`rcsim.models.errors`) and the
atomic file writer (:mod:`rcsim.models.atomic`).  Everything else builds on this layer.

Must not import: rcsim.spacecraft, rcsim.lookup, rcsim.analysis, rcsim.
"""
