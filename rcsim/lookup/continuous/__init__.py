"""Continuous-torque attitude controllers of the DAI papers.

Wilt & Sands 2022 (001); Smeresky & Rizzo 2020 (002).

Owns the sinusoidal trajectory (quiescent / maneuver / observation periods, :mod:`.trajectory`),
the rigid-body regression matrix Phi and the nonlinear feedforward ``u = J wd_dot + wd x J wd``
(:mod:`.regression`), the discrete Luenberger observer (:mod:`.observer`) and the batched step
functions FFD, FB (PDI with the ``w x J w`` decoupling term), FFD+FB and the hybrid FFD+FB+DAI
whose self-awareness statement learns Theta_hat by the Moore-Penrose pseudo-inverse
(:mod:`.controllers`).  Controllers see arrays (measured Euler angles), never the simulator;
gains are data (``rcsim.models.dai``).  Imports ``models`` and ``spacecraft``.

Must not import: rcsim.lookup.pattern_recognition, rcsim.lookup.phase_plane, rcsim.lookup.registry,
rcsim.analysis.

Only imported by: rcsim.analysis.apps.studies.
"""
