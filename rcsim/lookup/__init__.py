"""Attitude controllers and their tables: phase-plane baseline, pattern-recognition lookup
(static, and adaptive: :mod:`rcsim.lookup.adaptive`), tables regenerated for failed jets
(:mod:`rcsim.lookup.jet_sets`), the jet allocator for any jet layout (objective: the profile's
``allocation``)
(:mod:`rcsim.lookup.allocator`, :mod:`rcsim.lookup.allocator_controller`), channel tables for
layouts whose jets torque several axes (:mod:`rcsim.lookup.channels`,
:mod:`rcsim.lookup.channel_generation`) and the per-jet response database
(:mod:`rcsim.lookup.response_database`).

Owns the controllers (batched step functions: navigation arrays in, jet on-times out, explicit
state) and the generation/refinement of lookup tables.  Controllers see arrays, never the
simulator.  Imports ``rcsim.models`` and ``rcsim.spacecraft``.

Must not import: rcsim.analysis, rcsim.
"""
