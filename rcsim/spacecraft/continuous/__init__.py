"""Continuous-torque attitude physics of the DAI papers (Wilt & Sands 2022; Smeresky & Rizzo 2020).

Owns the plant side of the continuous-torque study: the rigid DAI spacecraft stepped in MuJoCo
over many runs at once (:mod:`.plant`), the ideal three-axis torque actuator and the three
single-gimbal CMGs with their Jacobian, determinant and pseudo-inverse steering (:mod:`.cmg`),
the gravity-gradient and aerodynamic-drag torques at 150 km with 001 App. C's atmosphere
(:mod:`.disturbances`) and the 3-2-1 Euler-angle / quaternion kinematics shared with the
controllers (:mod:`.kinematics`). Imports ``models`` only.

Must not import: rcsim.spacecraft.simulation, rcsim.lookup, rcsim.analysis.

Only imported by: rcsim.lookup.continuous, rcsim.analysis.apps.studies.
"""
