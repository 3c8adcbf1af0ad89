"""The simulated spacecraft: vehicle parameters, jets, propulsion, navigation, batched physics.

Owns everything between a controller's jet on-time commands and the navigation state it reads
back: building per-run MuJoCo models (:mod:`spacecraft.vehicle`), a user's vehicle file and its
model (:mod:`spacecraft.vehicle_file`), valve limits and propellant bookkeeping
(:mod:`spacecraft.propulsion`), propellant that runs out (:mod:`spacecraft.propellant`), valve
timing and jet faults (:mod:`spacecraft.valves`), each control cycle cut exactly at the jets'
switch instants (:mod:`spacecraft.pieces`), sensors (:mod:`spacecraft.sensors`),
attitude/rate errors (:mod:`spacecraft.navigation`), dispersions and the per-run seeding rule
(:mod:`spacecraft.dispersions`, :mod:`spacecraft.effect_draws`), the closed loop over many runs
at once (:mod:`spacecraft.simulation`, its record :mod:`spacecraft.history`) and what it refuses
before flying (:mod:`spacecraft.guards`).  Imports ``models`` only.

Must not import: lookup, analysis, rcsim.
"""
