"""Attitude controllers and their tables: phase-plane baseline, pattern-recognition lookup
(static, and adaptive: :mod:`lookup.adaptive`), tables regenerated for failed jets
(:mod:`lookup.jet_sets`), the minimum-propellant jet allocator for any jet layout
(:mod:`lookup.allocator`, :mod:`lookup.allocator_controller`), channel tables for layouts
whose jets torque several axes (:mod:`lookup.channels`, :mod:`lookup.channel_generation`) and
the per-jet response database (:mod:`lookup.response_database`).

Owns the controllers (batched step functions: navigation arrays in, jet on-times out, explicit
state) and the generation/refinement of lookup tables.  Controllers see arrays, never the
simulator.  Imports ``models`` and ``spacecraft``.

Must not import: analysis, rcsim.
"""
