"""The per-jet response database (Gambone sec. IV): every jet fired alone, under dispersions.

For each jet, each on-time of :data:`ON_TIMES_S` at or above the vehicle's minimum on-time
(a shorter pulse is one its valves never make: every such row would be zero and pull the
slope toward zero; :func:`flown_on_times` drops them) and each of ``n_vehicles`` dispersed
vehicles
(the vehicle file's Table 5-format dispersions, drawn as a campaign draws them: vehicle ``i``
from ``SeedSequence(seed, spawn_key=(i,))``), the vehicle is flown from rest with that jet
alone firing one pulse from t = 0, and the flight is read at the end of the pulse's cycle:

* ``dw_<axis>_rad_s``: the body-rate change (simulated);
* ``dv_<x,y,z>_m_s``: the CG velocity change in body axes, the jet's impulse as flown
  (dispersed thrust and pointing) over the vehicle's mass -- exact to first order in the
  attitude change during the pulse (below 0.1 deg for the longest pulse on the packaged
  vehicles).

A vehicle with valve timing (:meth:`Vehicle.timing`) is flown with it: the pulse commanded
over ``[0, t]`` thrusts over ``[d + d_o, d + t + d_c]`` (command delay, the jet's opening and
closing latency), so the flight lasts until that thrust has ended, and the frame gains
``thrust_s``, the time the jet thrust (``max(0, t + d_c - d_o)``, as the simulation delivered
it).

:func:`response_summary` fits, per jet, the rate and velocity change per second of firing
(least squares through the origin over every on-time and vehicle; per second of thrust,
``thrust_s``, when the frame has it: the jet's own response, the valve's offset apart) and its
spread over the dispersed vehicles (the standard deviation of the per-vehicle slopes): the jet
model an allocator can use (:class:`rcsim.lookup.allocator.Allocator` ``D`` and ``G``).  All the
flights are one batched simulation.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from rcsim.lookup.open_loop import OpenLoopController
from rcsim.models.errors import InputError
from rcsim.spacecraft.dispersions import DispersionSigmas, draw_runs
from rcsim.spacecraft.flight_model import jet_wrench_B
from rcsim.spacecraft.navigation import Guidance
from rcsim.spacecraft.simulation import simulate_batch
from rcsim.spacecraft.vehicle import Vehicle
from rcsim.spacecraft.vehicle.model import AXES

#: On-times fired [s]: from a 10 ms pulse to eight control cycles.
ON_TIMES_S = (0.01, 0.02, 0.04, 0.08, 0.16, 0.32)
RATE_COLUMNS = tuple(f"dw_{a}_rad_s" for a in AXES)
VELOCITY_COLUMNS = tuple(f"dv_{a}_m_s" for a in "xyz")


def flown_on_times(on_times_s, min_on_s: float) -> tuple[np.ndarray, np.ndarray]:
    """The on-times a vehicle's valves make (at or above ``min_on_s`` [s], the valve rule of
    :func:`rcsim.spacecraft.propulsion.apply_valve_limits`) and those dropped, both [s]."""
    on_times = np.asarray(on_times_s, float)
    made = on_times >= min_on_s
    return on_times[made], on_times[~made]


def response_database(
    vehicle: Vehicle,
    *,
    n_vehicles: int = 64,
    seed: int = 1,
    on_times_s=ON_TIMES_S,
    nthread: int = 0,
) -> pd.DataFrame:
    """Fly every jet alone (module docstring); one row per (jet, on-time, vehicle).

    Columns: ``jet`` (name), ``jet_number`` (1-based), ``on_time_s``, ``vehicle`` (dispersed
    vehicle index), :data:`RATE_COLUMNS`, :data:`VELOCITY_COLUMNS`; with valve timing,
    ``thrust_s`` (module docstring).  On-times below the vehicle's minimum on-time are not
    flown (:func:`flown_on_times`); ``frame.attrs`` records them (``dropped_on_times_s``) and
    the minimum (``min_on_s``).

    Raises
    ------
    InputError
        ``n_vehicles`` < 1, an on-time not in (0, 1] s, or every on-time below the vehicle's
        minimum on-time.
    """
    if isinstance(n_vehicles, bool) or not isinstance(n_vehicles, int) or n_vehicles < 1:
        raise InputError(f"must be an integer >= 1, got {n_vehicles!r}", parameter="n_vehicles")
    on_times = np.asarray(on_times_s, float)
    if not (np.isfinite(on_times).all() and (on_times > 0).all() and (on_times <= 1).all()):
        raise InputError(f"must be in (0, 1] s, got {on_times.tolist()}", parameter="on_times_s")
    d = vehicle.definition
    on_times, dropped = flown_on_times(on_times, d.min_on_s)
    if not on_times.size:
        raise InputError(
            f"every on-time is below {d.source}'s minimum on-time {d.min_on_s:g} s "
            f"(got {dropped.tolist()})",
            parameter="on_times_s",
        )
    n_jets = d.n_jets
    sigmas = DispersionSigmas.from_table(d.dispersion_table())
    dispersed = draw_runs(vehicle.nominal(1), sigmas, seed, np.arange(n_vehicles))
    jet, k, run = (
        a.ravel()
        for a in np.meshgrid(
            np.arange(n_jets), np.arange(on_times.size), np.arange(n_vehicles), indexing="ij"
        )
    )
    n = jet.size
    params = dispersed.params.take(run)
    total = np.zeros((n, n_jets))
    total[np.arange(n), jet] = on_times[k]
    cycle = vehicle.control.cycle_s
    timing = vehicle.timing(n)
    # Read after the thrust has ended: the command delay and the closing latency move it on.
    lag = 0.0 if timing is None else d.command_delay_s + float(d.close_delays_s().max())
    duration = float(np.ceil((on_times.max() + lag) / cycle - 1e-9) * cycle)
    history = simulate_batch(
        params,
        OpenLoopController(total, cycle),
        Guidance.rate(np.zeros((n, 3))),
        duration,
        vehicle=vehicle,
        timing=timing,
        tank=None,  # every pulse from the wet vehicle (module docstring)
        nthread=nthread,
    )
    dw = history.final.omega_B
    flown = history.flown_params
    assert flown is not None  # a simulation's history always has them
    force_B = jet_wrench_B(flown, vehicle.model)[:, :3, :]  # (n, 3, n_jets) [N]
    impulse = np.einsum("nwj,nj->nw", force_B, history.propulsion.on_time_s)
    dv = impulse / flown.mass_kg[:, None]
    frame = pd.DataFrame(
        {
            "jet": np.asarray(d.jet_names)[jet],
            "jet_number": jet + 1,
            "on_time_s": on_times[k],
            "vehicle": run,
        }
    )
    for a, col in enumerate(RATE_COLUMNS):
        frame[col] = dw[:, a]
    for a, col in enumerate(VELOCITY_COLUMNS):
        frame[col] = dv[:, a]
    if timing is not None:
        frame["thrust_s"] = history.propulsion.on_time_s[np.arange(n), jet]
    frame.attrs["vehicle"] = d.source
    frame.attrs["min_on_s"] = d.min_on_s
    frame.attrs["dropped_on_times_s"] = dropped.tolist()
    return frame


def response_summary(frame: pd.DataFrame) -> pd.DataFrame:
    """Per jet: slope per second of firing of every response column (least squares through
    the origin over all rows) and ``<column>_per_s_sd``, the standard deviation over the
    dispersed vehicles of each vehicle's own slope.  One row per jet, in jet order."""
    cols = list(RATE_COLUMNS + VELOCITY_COLUMNS)
    t = frame["thrust_s" if "thrust_s" in frame else "on_time_s"].to_numpy()
    values = frame[cols].to_numpy()
    key = frame["jet_number"].to_numpy()
    veh = frame["vehicle"].to_numpy()
    rows = []
    for j in np.unique(key):  # one row per jet (n_jets iterations, post-processing)
        mine = key == j
        tj, vj, rj = t[mine], values[mine], veh[mine]
        slope = tj @ vj / (tj @ tj)
        # per-vehicle slopes, vectorised over vehicles with bincount sums
        tt = np.bincount(rj, weights=tj * tj)
        per_vehicle = np.stack(
            [np.bincount(rj, weights=tj * vj[:, c]) for c in range(len(cols))], 1
        )
        slopes = per_vehicle[tt > 0] / tt[tt > 0, None]
        sd = slopes.std(axis=0, ddof=1) if slopes.shape[0] > 1 else np.zeros(len(cols))
        row = {"jet": frame.loc[mine, "jet"].iloc[0], "jet_number": int(j)}
        row.update({f"{c}_per_s": slope[i] for i, c in enumerate(cols)})
        row.update({f"{c}_per_s_sd": sd[i] for i, c in enumerate(cols)})
        rows.append(row)
    return pd.DataFrame(rows)
