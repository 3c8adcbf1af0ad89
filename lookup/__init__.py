"""Attitude controllers and their tables: phase-plane baseline, pattern-recognition lookup
(static, and adaptive: :mod:`lookup.adaptive`), tables regenerated for failed jets
(:mod:`lookup.jet_sets`).

Owns the controllers (batched step functions: navigation arrays in, jet on-times out, explicit
state) and the generation/refinement of lookup tables.  Controllers see arrays, never the
simulator.  Imports ``models`` and ``spacecraft``.

Must not import: analysis, rcsim.
"""
