"""The simulated spacecraft: vehicle parameters, jets, propulsion, navigation, batched physics.

Owns everything between a controller's jet on-time commands and the navigation state it reads
back: building per-run MuJoCo models (:mod:`spacecraft.vehicle`), turning on-times into exact
per-step duty (:mod:`spacecraft.propulsion`), attitude/rate errors (:mod:`spacecraft.navigation`),
dispersions and the per-run seeding rule (:mod:`spacecraft.dispersions`), the closed loop over
many runs at once (:mod:`spacecraft.simulation`) and what it refuses before flying
(:mod:`spacecraft.guards`).  Imports ``models`` only; never ``lookup`` or ``analysis``.
"""
