"""Physically odd but legal vehicle files: warnings, not errors.

A vehicle file's ranges (:mod:`rcsim.spacecraft.vehicle.file_sections`) refuse what no
spacecraft has (a mass in grams, a thrust in mN).  What is possible but unusual enough to be a
slip is said as a warning, once, where a user sees it: ``rcsim vehicle check`` lists them, and
every command that flies a vehicle file prints them (``rcsim: warning: ...``) before its work.
Each warning gives the figure, the rule and why the rule matters:

* **jet acceleration**: one jet's thrust over the wet mass above :data:`MAX_JET_ACCEL_G` of
  g.  Attitude-control jets give 1e-4 to 1e-2 g (the Space Shuttle's 3,870 N primary jets on
  the ~100 t orbiter, 0.004 g; the paper's 22 N on 3.5 t, 6.5e-4 g): g-order accelerations are
  a translation engine's, or a thrust or mass in other units;
* **minimum pulse against the valves**: a commanded pulse shorter than ``open_delay_s -
  close_delay_s`` never opens the valve (:mod:`rcsim.spacecraft.valves`), so a ``min_on_s``
  below it lets the controllers command pulses that deliver nothing;
* **the maneuver rate against the jets** (the flight-software profile's
  ``maneuver_rate_deg_s``, per axis direction, from the jets' pure-axis authority ``alpha``):
  the maneuver ends at the profile's maneuver limit, where the controllers null the rate; if
  braking from the maneuver rate, ``rate^2 / (2 alpha)``, takes more turn than that limit, every
  maneuver overshoots its target.  And if one minimum pulse of the jets that turn an axis,
  ``alpha * min_on_s``, changes the rate by more than the maneuver rate, the maneuver rate
  cannot be flown finer than that pulse.

The issue that asked for these (31) phrased the last as "a maneuver rate the jets cannot reach
within one cycle"; read literally it would warn on the paper's own vehicle, whose roll jets need
8.7 cycles to reach 0.2 deg/s -- by design.  The two rules above are the consequences that
matter in flight, with the figure each is measured against.
"""

from __future__ import annotations

import math

import numpy as np

from rcsim.spacecraft.modes.reader import mode_warnings
from rcsim.spacecraft.pulse_file import pulse_warnings
from rcsim.spacecraft.vehicle.axis_authority import axis_authorities
from rcsim.spacecraft.vehicle.definition import VehicleDef
from rcsim.spacecraft.vehicle.run_parameters import G0_M_S2

#: Largest single-jet acceleration of the whole vehicle that passes without a word [g]: five
#: times the highest of the attitude-control jets above (Shuttle orbiter, 0.004 g), 34 times
#: below a 1,000 N jet on a 150 kg satellite (0.68 g).
MAX_JET_ACCEL_G = 0.02


def _jets_named(names: list[str]) -> str:
    """``jet_01`` / ``jet_01, jet_02`` / ``jet_01, jet_02 and 14 more``."""
    shown = ", ".join(names[:2])
    return shown + (f" and {len(names) - 2} more" if len(names) > 2 else "")


def sanity_warnings(vehicle: VehicleDef, authority_rad_s2: np.ndarray | None = None) -> list[str]:
    """The warnings a vehicle file earns (module docstring), one line each; empty when none.

    Parameters
    ----------
    vehicle : VehicleDef
    authority_rad_s2 : ndarray, (6,), optional
        Pure-axis authority of +roll, -roll, +pitch, -pitch, +yaw, -yaw [rad/s^2] (0: the
        direction is unreachable), as ``rcsim vehicle check`` computed it; solved here (six
        small LPs) when not given.
    """
    d = vehicle
    out: list[str] = []
    accel_g = np.array([j.thrust_n for j in d.jets]) / d.mass_kg / G0_M_S2
    high = [j.name for j, a in zip(d.jets, accel_g) if a > MAX_JET_ACCEL_G]
    if high:
        worst = int(np.argmax(accel_g))
        out.append(
            f"{_jets_named(high)}: {d.jets[worst].thrust_n:g} N on {d.mass_kg:g} kg accelerates "
            f"the vehicle at {accel_g[worst]:.3g} g, over {MAX_JET_ACCEL_G:g} g: attitude-control "
            "jets give 1e-4 to 1e-2 g (the Shuttle's 3,870 N primary jets on the ~100 t orbiter "
            "0.004 g); a thrust_n or mass_kg in other units?"
        )
    dead = np.array([j.open_delay_s - j.close_delay_s for j in d.jets])
    blind = [j.name for j, g in zip(d.jets, dead) if g > 0 and d.min_on_s < g]
    if blind:
        gap = float(dead.max())
        out.append(
            f"{_jets_named(blind)}: a pulse shorter than open_delay_s - close_delay_s = "
            f"{gap * 1e3:g} ms never opens the valve, and min_on_s = {d.min_on_s * 1e3:g} ms lets "
            f"the controllers command one: raise min_on_s to at least {gap * 1e3:g} ms"
        )
    if authority_rad_s2 is None:
        authority_rad_s2 = axis_authorities(d)
    out += _maneuver_rate_warnings(d, np.asarray(authority_rad_s2, float))
    out += mode_warnings(d.modes, d.timestep_s)
    out += pulse_warnings(
        d.pulse, d.blowdown, min_on_s=d.min_on_s, isp_s=d.isp_s, propellant_kg=d.propellant_kg
    )
    return out


def _maneuver_rate_warnings(d: VehicleDef, alpha: np.ndarray) -> list[str]:
    c = d.control
    rate, limit = c.maneuver_rate_rad_s, c.maneuver_limit_rad
    names = ("+roll", "-roll", "+pitch", "-pitch", "+yaw", "-yaw")
    reachable = alpha > 0
    out = []
    if reachable.any():
        braking = np.where(reachable, rate**2 / (2 * np.where(reachable, alpha, 1.0)), 0.0)
        k = int(np.argmax(braking))
        if braking[k] > limit:
            slow = [n for n, b in zip(names, braking) if b > limit]
            out.append(
                f"control.maneuver_rate_deg_s = {math.degrees(rate):g}: braking from it at full "
                f"{names[k]} authority ({math.degrees(alpha[k]):.3g} deg/s^2) takes "
                f"{math.degrees(braking[k]):.3g} deg of turn, more than the maneuver limit "
                f"control.maneuver_limit_deg = {math.degrees(limit):g} ({', '.join(slow)}): "
                "every maneuver overshoots its target; lower the maneuver rate or raise the limit"
            )
        step = np.where(reachable, alpha * d.min_on_s, 0.0)
        k = int(np.argmax(step))
        if step[k] > rate:
            coarse = [n for n, s in zip(names, step) if s > rate]
            out.append(
                f"min_on_s = {d.min_on_s * 1e3:g} ms: one minimum pulse of the jets that give "
                f"{names[k]} its full authority changes its rate by "
                f"{math.degrees(step[k]):.3g} deg/s, {step[k] / rate:.2g} times the maneuver rate "
                f"control.maneuver_rate_deg_s = {math.degrees(rate):g} ({', '.join(coarse)}): "
                "the maneuver rate cannot be flown finer than that pulse"
            )
    return out
