"""The simulated spacecraft: vehicle parameters, jets, propulsion, navigation, batched physics.

Owns everything between a controller's jet on-time commands and the navigation state it reads
back: building per-run MuJoCo models (:mod:`spacecraft.vehicle`), turning on-times into exact
per-step duty (:mod:`spacecraft.propulsion`), attitude/rate errors (:mod:`spacecraft.navigation`),
dispersions (:mod:`spacecraft.dispersions`) and the closed loop over many runs at once
(:mod:`spacecraft.simulation`).  Imports ``models`` only; never ``lookup`` or ``analysis``.
"""
