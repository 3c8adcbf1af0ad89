"""What a vehicle's jets can do: the analyses of ``rcsim vehicle check``.

All from the nominal vehicle file, jets at full thrust (SI inside):

* the jet-by-jet force and torque matrix about the CG (:meth:`VehicleDef.force_torque`);
* control authority per axis and direction: the largest angular acceleration about ``+-axis``
  with the other two axes' angular accelerations zero, every jet at most fully on (an LP over
  the jets' duties, ``0 <= u <= 1``); also as a pure couple (zero net force too), and the
  least propellant per unit of rate change along the axis;
* unreachable directions: an axis direction is reachable when that LP's optimum is positive;
  when every ``+-axis`` is, the torques positively span R^3 and every direction is reachable;
  otherwise a sample of the sphere describes the unreachable region;
* jet-out cases: for every jet failed off, the axis directions lost and the authority left.

Angular accelerations are ``I^-1 tau`` with the full inertia (products included), so a jet's
"roll" authority is the roll acceleration it makes, not its roll torque.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations

import numpy as np
from scipy.optimize import linprog

from rcsim.spacecraft.pulse_file import pulse_check_lines
from rcsim.spacecraft.vehicle.axis_authority import (
    DIRECTIONS,
    direction_name,
    pure_axis_authority,
    reachable,
)
from rcsim.spacecraft.vehicle.definition import PAPER_RATE_ERROR_DEG_S
from rcsim.spacecraft.vehicle.file_schema import VehicleDef
from rcsim.spacecraft.vehicle.mjcf import force_torque
from rcsim.spacecraft.vehicle.sanity import sanity_warnings


def lp_count(n_jets: int, *, pairs: bool) -> int:
    """Linear programs :func:`check_vehicle` solves at most for ``n_jets`` jets (without the
    unreachable-direction sample): the six directions' authority, pure couple (two LPs each)
    and propellant; per jet out, authority and couple again; per pair out, one per direction.
    The cost of ``rcsim vehicle check`` grows with it: n^2 with the pairs."""
    count = 6 * 5 + n_jets * 6 * 4
    if pairs:
        count += n_jets * (n_jets - 1) // 2 * 6
    return count


def propellant_per_rate(
    accel: np.ndarray, mdot: np.ndarray, axis: int, sign: int, available: np.ndarray
) -> float:
    """Least propellant [kg] per rad/s of rate change along ``sign * axis`` (inf if none)."""
    target = np.zeros(3)
    target[axis] = sign
    bounds = [(0.0, None if available[j] else 0.0) for j in range(accel.shape[1])]
    res = linprog(mdot, A_eq=accel, b_eq=target, bounds=bounds, method="highs")
    return float(res.fun) if res.status == 0 else float("inf")


@dataclass(frozen=True)
class AxisAuthority:
    """Authority along one axis direction."""

    direction: str
    accel_rad_s2: float  # 0: unreachable
    torque_n_m: float
    force_n: float
    jets_used: int
    couple_accel_rad_s2: float  # with zero net force
    propellant_kg_per_rad_s: float


@dataclass(frozen=True)
class JetOut:
    """One jet failed off."""

    jet: str
    lost: tuple  # direction names no longer reachable
    worst_left: float  # smallest authority left / full authority over reachable directions
    no_couple: tuple  # directions with no pure couple left


@dataclass(frozen=True)
class VehicleCheck:
    """Everything ``rcsim vehicle check`` prints."""

    force_torque: np.ndarray  # (6, n)
    axes: tuple  # AxisAuthority x 6
    unreachable: tuple  # direction names
    unreachable_fraction: float  # of sampled directions (0 when every axis is reachable)
    jet_out: tuple  # JetOut per jet
    pairs_losing_an_axis: tuple | None  # (jet, jet) names; None: the pairs were not searched


def check_vehicle(vehicle: VehicleDef, *, pairs: bool = True, step=None) -> VehicleCheck:
    """Run every analysis of the module docstring on ``vehicle``.

    ``pairs``: search the two-jets-out cases (n (n - 1) / 2 of them); without it
    ``pairs_losing_an_axis`` is None.  ``step``: called with no argument after each jet-out
    and each pair case (a progress bar's update).
    """
    ft = force_torque(vehicle)
    accel = np.linalg.solve(vehicle.inertia_kg_m2, ft[3:])
    force = ft[:3]
    mdot = vehicle.mass_flow_kg_s()
    n = vehicle.n_jets
    every = np.ones(n, bool)
    full = {}
    axes = []
    for a, s in DIRECTIONS:
        value, u = pure_axis_authority(accel, a, s, every)
        full[(a, s)] = value
        couple, _ = pure_axis_authority(accel, a, s, every, force)
        if u is None:
            axes.append(AxisAuthority(direction_name(a, s), 0.0, 0.0, 0.0, 0, couple, np.inf))
            continue
        axes.append(
            AxisAuthority(
                direction_name(a, s),
                value,
                float((ft[3:] @ u)[a]),
                float(np.linalg.norm(force @ u)),
                int((u > 1e-9).sum()),
                couple,
                propellant_per_rate(accel, mdot, a, s, every),
            )
        )
    unreachable = tuple(direction_name(a, s) for (a, s), v in full.items() if v <= 0)
    fraction = 0.0
    if unreachable:
        k = 500
        i = np.arange(k) + 0.5
        polar, turn = np.arccos(1 - 2 * i / k), np.pi * (1 + 5**0.5) * i
        dirs = np.stack(
            [np.cos(turn) * np.sin(polar), np.sin(turn) * np.sin(polar), np.cos(polar)], 1
        )
        bad = sum(
            linprog(np.zeros(n), A_eq=accel, b_eq=d, bounds=(0, None), method="highs").status != 0
            for d in dirs
        )
        fraction = bad / k
    outs = []
    for j in range(n):
        avail = every.copy()
        avail[j] = False
        lost, no_couple, worst = [], [], np.inf
        for a, s in DIRECTIONS:
            value, _ = pure_axis_authority(accel, a, s, avail)
            if value <= 0 < full[(a, s)]:
                lost.append(direction_name(a, s))
            elif full[(a, s)] > 0:
                worst = min(worst, value / full[(a, s)])
            if pure_axis_authority(accel, a, s, avail, force)[0] <= 0:
                no_couple.append(direction_name(a, s))
        outs.append(JetOut(vehicle.jets[j].name, tuple(lost), float(worst), tuple(no_couple)))
        if step is not None:
            step()
    if not pairs:
        return VehicleCheck(ft, tuple(axes), unreachable, fraction, tuple(outs), None)
    lost_pairs = []
    for j, k in combinations(range(n), 2):
        avail = every.copy()
        avail[[j, k]] = False
        if any(full[(a, s)] > 0 and not reachable(accel, a, s, avail) for a, s in DIRECTIONS):
            lost_pairs.append((vehicle.jets[j].name, vehicle.jets[k].name))
        if step is not None:
            step()
    return VehicleCheck(ft, tuple(axes), unreachable, fraction, tuple(outs), tuple(lost_pairs))


def check_text(vehicle: VehicleDef, result: VehicleCheck) -> str:
    """The printout of ``rcsim vehicle check`` (degrees, N, N m, grams at this boundary)."""
    d = vehicle
    inertia = d.inertia_kg_m2
    w = max(10, *(len(j.name) + 1 for j in d.jets))  # the jet column fits the longest name
    out = [
        f"vehicle {d.name!r} ({d.source}): {d.n_jets} jets, mass {d.mass_kg:g} kg, "
        f"CG {list(d.cg_m)} m, Isp {d.isp_s:g} s, minimum on-time {d.min_on_s * 1e3:g} ms",
        f"inertia about the CG: moments {np.diag(inertia).tolist()} kg m^2, products "
        f"[{inertia[0, 1]:g}, {inertia[0, 2]:g}, {inertia[1, 2]:g}]; principal "
        f"{np.round(np.linalg.eigvalsh(inertia), 3).tolist()}",
    ]
    if d.delay_keys:  # the vehicle's nominal valve timing, flown by every flight of it
        ms = lambda v: "/".join(f"{x * 1e3:g}" for x in sorted(set(v.tolist())))  # noqa: E731
        out.append(
            f"valve timing: command delay {d.command_delay_s * 1e3:g} ms; jets open "
            f"{ms(d.open_delays_s())} ms, close {ms(d.close_delays_s())} ms after their "
            "command edges"
        )
    out.append(f"flight-software profile: {d.control.describe()}")
    own = "; ".join(f"{k} = {v:g}" for k, v in d.failure.items())
    out.append(
        f"failure criterion of its campaigns: {own} ([failure])"
        if own
        else "failure criterion of its campaigns: the paper's, rate_error_deg_s = "
        f"{PAPER_RATE_ERROR_DEG_S:g} (Gambone sec. III; no [failure])"
    )
    out += pulse_check_lines(
        d.pulse,
        d.blowdown,
        min_on_s=d.min_on_s,
        isp_s=d.isp_s,
        propellant_kg=d.propellant_kg,
        n_jets=d.n_jets,
        authority={ax.direction: ax.accel_rad_s2 for ax in result.axes},
    )
    out += [
        "",
        "Force [N] and torque about the CG [N m] of each jet at full thrust:",
        f"{'jet':{w}s}"
        + "".join(f"{c:>9s}" for c in ("Fx", "Fy", "Fz", "Tx", "Ty", "Tz"))
        + "   axes torqued",
    ]
    ft = result.force_torque
    # The matrix is derived from the compiled model's site frames, as the flight's is: a
    # component that is zero by design comes out as rounding residue (~1e-15), printed as 0.
    # An axis is torqued above 1e-9 of the largest torque of any jet (:func:`torque_signs`'s
    # rule), so a jet through the CG torques none.
    ft_shown = np.where(np.abs(ft) > 1e-9 * np.abs(ft).max(), ft, 0.0)
    big = np.abs(ft[3:]) > 1e-9 * np.abs(ft[3:]).max()
    for j, jet in enumerate(d.jets):
        torqued = "".join("RPY"[a] for a in range(3) if big[a, j])
        row = "".join(f"{v:9.3f}" for v in ft_shown[:, j])
        out.append(f"{jet.name:{w}s}" + row + f"   {torqued}")
    out += [
        "",
        "Control authority per axis and direction (jets at most fully on, the other two axes' "
        "angular acceleration zero):",
        f"{'direction':10s}{'deg/s^2':>10s}{'torque N m':>12s}{'|force| N':>11s}{'jets':>6s}"
        f"{'pure couple deg/s^2':>21s}{'propellant g per deg/s':>24s}",
    ]
    for ax in result.axes:
        if ax.accel_rad_s2 <= 0:
            out.append(f"{ax.direction:10s}  UNREACHABLE")
            continue
        out.append(
            f"{ax.direction:10s}{np.degrees(ax.accel_rad_s2):10.4f}{ax.torque_n_m:12.3f}"
            f"{ax.force_n:11.3f}{ax.jets_used:6d}{np.degrees(ax.couple_accel_rad_s2):21.4f}"
            f"{ax.propellant_kg_per_rad_s * np.pi / 180 * 1e3:24.4f}"
        )
    out.append("")
    if not result.unreachable:
        out.append(
            "Unreachable directions: none (every +-axis is reachable, so the jets' torques "
            "positively span every direction)"
        )
    else:
        out.append(
            f"Unreachable directions: {', '.join(result.unreachable)}; "
            f"{result.unreachable_fraction * 100:.1f} % of sampled rate-change directions"
        )
    out += ["", "Jet-out cases (one jet failed off):"]
    # A direction the full vehicle has no pure couple for is said once, not on every line.
    nominal = [ax.direction for ax in result.axes if ax.couple_accel_rad_s2 <= 0]
    if nominal:
        out.append(
            f"  (the full vehicle already has no pure couple for {', '.join(nominal)}; "
            "below, only the directions a jet out adds)"
        )
    lost_w = max(24, *(len(", ".join(jo.lost)) for jo in result.jet_out))
    for jo in result.jet_out:
        left = "-" if not np.isfinite(jo.worst_left) else f"{jo.worst_left * 100:5.1f} %"
        added = [c for c in jo.no_couple if c not in nominal]
        label = "no pure couple also for" if nominal else "no pure couple for"
        out.append(
            f"  {jo.jet:{w}s} loses: {', '.join(jo.lost) or 'no axis':{lost_w}s} least authority "
            f"left {left:>7s}; {label}: {', '.join(added) or 'none'}"
        )
    losing = [jo.jet for jo in result.jet_out if jo.lost]
    out.append(
        f"  -> {len(losing)} of {d.n_jets} single jets out lose an axis direction"
        + (f": {', '.join(losing)}" if losing else "")
    )
    pairs = result.pairs_losing_an_axis
    n_pairs = d.n_jets * (d.n_jets - 1) // 2
    if pairs is None:  # skipped: say so, not "0 of N" about a search that was not made
        out.append(f"Two jets out: not searched (the {n_pairs} pairs were skipped)")
    else:
        more = " ..." if len(pairs) > 12 else ""
        shown = ", ".join(f"{a}+{b}" for a, b in pairs[:12]) + more
        out.append(
            f"Two jets out: {len(pairs)} of {n_pairs} pairs lose an axis direction"
            + (f": {shown}" if pairs else "")
        )
    warnings = sanity_warnings(d, np.array([ax.accel_rad_s2 for ax in result.axes]))
    out += ["", "Warnings (physically odd but legal values):" if warnings else "Warnings: none"]
    out += [f"  {w}" for w in warnings]
    return "\n".join(out) + "\n"


def unreachable_command(vehicle: VehicleDef, change_rad_s) -> str | None:
    """Why the jets cannot give the rate change ``change_rad_s`` (3,), or None when they can.

    The answer names the command's direction (its axis directions together, e.g. ``"(-roll,
    -pitch, -yaw) together"``: what is unreachable is that combined direction, not each axis)
    and which of its axis directions the jets cannot reach even alone, or that they reach
    each alone."""
    change = np.asarray(change_rad_s, float)
    if not np.any(change):
        return None
    accel = np.linalg.solve(vehicle.inertia_kg_m2, force_torque(vehicle)[3:])
    n = vehicle.n_jets
    unit = change / np.abs(change).max()
    res = linprog(np.zeros(n), A_eq=accel, b_eq=unit, bounds=(0, None), method="highs")
    if res.status == 0:
        return None
    every = np.ones(n, bool)
    names = [direction_name(a, int(np.sign(change[a]))) for a in range(3) if change[a] != 0]
    lost = [
        direction_name(a, int(np.sign(change[a])))
        for a in range(3)
        if change[a] != 0 and pure_axis_authority(accel, a, int(np.sign(change[a])), every)[0] <= 0
    ]
    if len(names) == 1:
        return f"no jet combination turns the vehicle toward {names[0]}"
    toward = f"no jet combination turns the vehicle toward ({', '.join(names)}) together"
    if lost:
        return f"{toward}, nor even toward {' or '.join(lost)} alone"
    return f"{toward}, although it reaches each of {', '.join(names)} alone"


def torque_signs(vehicle: VehicleDef) -> np.ndarray:
    """Sign of each jet's torque about roll, pitch, yaw, (n_jets, 3) in {-1, 0, 1}: the
    vehicle's own Table 2 (a component below 1e-9 of the largest is zero)."""
    torque = force_torque(vehicle)[3:].T
    return np.where(np.abs(torque) > 1e-9 * np.abs(torque).max(), np.sign(torque), 0).astype(int)


def jet_map_mismatch(vehicle: VehicleDef, jet_map: np.ndarray) -> str | None:
    """How ``vehicle``'s jets differ from ``jet_map`` (n, 3) signs (Table 2), or None."""
    signs = torque_signs(vehicle)
    if signs.shape != np.shape(jet_map):
        return f"it has {vehicle.n_jets} jets, the jet map {len(jet_map)}"
    for j in range(vehicle.n_jets):
        if not np.array_equal(signs[j], jet_map[j]):
            return (
                f"{vehicle.jets[j].name} torques roll/pitch/yaw with signs {signs[j].tolist()} "
                f"(the jet map: {np.asarray(jet_map[j]).tolist()})"
            )
    return None


def vehicle_report(vehicle, *, pairs: bool = True) -> str:
    """What ``rcsim vehicle check`` prints for ``vehicle`` (a
    :class:`~rcsim.spacecraft.vehicle.Vehicle`, a packaged name or a vehicle file): the
    force/torque matrix, the authority per axis, the unreachable directions, the jet-out
    cases (and, with ``pairs``, the two-jets-out search), and the flight-software profile."""
    from rcsim.spacecraft.vehicle.vehicle import Vehicle

    definition = Vehicle.load(vehicle).definition
    return check_text(definition, check_vehicle(definition, pairs=pairs))
