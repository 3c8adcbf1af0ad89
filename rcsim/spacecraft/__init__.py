"""The simulated spacecraft: vehicle parameters, jets, propulsion, navigation, batched physics.

Owns everything between a controller's jet on-time commands and the navigation state it reads
back: building per-run MuJoCo models (:mod:`rcsim.spacecraft.vehicle`), a user's vehicle file and
its model (:mod:`rcsim.spacecraft.vehicle`), valve limits and propellant bookkeeping
(:mod:`rcsim.spacecraft.propulsion`), propellant that runs out (:mod:`rcsim.spacecraft.propellant`),
valve timing and jet faults (:mod:`rcsim.spacecraft.valves`), each control cycle cut exactly at the
jets' switch instants (:mod:`rcsim.spacecraft.pieces`), sensors (:mod:`rcsim.spacecraft.sensors`),
attitude/rate errors (:mod:`rcsim.spacecraft.navigation`), dispersions and the per-run seeding rule
(:mod:`rcsim.spacecraft.dispersions`, :mod:`rcsim.spacecraft.effect_draws`), a run's dispersions
as one standard-normal vector and back (:mod:`rcsim.spacecraft.standard_space`), the closed
loop over many runs at once (:mod:`rcsim.spacecraft.simulation`, its record
:mod:`rcsim.spacecraft.history`) and what it refuses before flying
(:mod:`rcsim.spacecraft.guards`).  Imports ``rcsim.models`` only.

Must not import: rcsim.lookup, rcsim.analysis, rcsim.
"""
