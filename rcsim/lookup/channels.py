"""Axis channels for coupled jet layouts: the recipes (solved once) and their delivery (per cycle).

Gambone sec. IV: the lookup logic "does not allow for a single thruster to be used for multiple
axes", and a per-jet database with torque-coupling-aware mapping is the way on.  For a vehicle
whose jets each torque two or three axes (``rcsim/models/vehicle/canted16.toml``) the lookup table's
columns are six *channels* (+roll, -roll, +pitch, -pitch, +yaw, -yaw;
:mod:`rcsim.models.tables.channels`) and the lookup logic runs on them unchanged (each channel has
one axis and one sign, so the roles it learns from the table are the channels themselves).  Two
pieces make that fly:

**Recipe** (:func:`solve_recipe`, once per vehicle and jet set).  For each channel the
allocator's LP (:class:`rcsim.lookup.allocator.Allocator`, nominal jet model of
:func:`rcsim.lookup.allocator_controller.jet_model`, translation priced at the propellant that would
null it -- exactly as the allocator controller prices it) gives the jets' on-times for a pure
rate change about the channel's axis; divided by the longest, they are the channel's fractions
(each in ``[0, 1]``, the longest 1).  The LP is homogeneous in the command, so the fractions do
not depend on its size.  A direction no jet combination left can turn (jets off) gets an empty
recipe: that channel is never fired, as a jet-off table's lost direction.

**Delivery** (:class:`ChannelMap`, every cycle, batched over runs).  The lookup logic commands
each channel an on-time ``c_k`` (``<=`` the cycle); jet ``j`` is asked for ``sum_k c_k f_kj``.
Two channels of different axes may share a jet (on canted16 the +pitch and +yaw recipes both
fire jets 5 and 14 nearly fully), so the sum can exceed the cycle.  Then the whole run's
command is **scaled** by ``cycle / max_j(sum)`` -- every channel alike, so the rate change of
the cycle keeps its direction and no coupled torque appears (capping the shared jet instead
would leave the other jets' coupling uncancelled) -- and what was not delivered stays in the
channels' remaining on-time: a channel's *delivered* time, not the clock, counts down its
firing, so a firing's total rate change is its table time's, only spread over more cycles.
**Minimum on-time**: a new pulse shorter than the vehicle's minimum is not made by the valves
(:class:`rcsim.spacecraft.propulsion.PropulsionParams`); such short shares (a trim jet's few
percent) are owed per jet and fired as one pulse of at least the minimum when they add up to
it, folded into a longer pulse of the same jet when it fires anyway, or rounded (to the minimum when
at least half of it is owed, else dropped) when no channel asks for the jet any more -- the
profile's ``min_pulse = "accumulate"``; ``"round-up"``
fires each short share at the minimum at once, ``"drop"`` does not fire it
(:mod:`rcsim.spacecraft.control_profile`).

Imports ``models``, ``spacecraft`` and the allocator only.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from rcsim.lookup.jet_numbers import jet_numbers
from rcsim.models.errors import InputError
from rcsim.models.tables import AXES, CHANNEL_MAP, CHANNELS, ChannelRecipe
from rcsim.spacecraft.control_profile import MIN_PULSE_POLICIES

if TYPE_CHECKING:
    from rcsim.spacecraft.vehicle import Vehicle

#: Size of the command the recipe LP is solved for [rad/s]: any positive value gives the same
#: fractions (the LP is homogeneous); 0.01 rad/s keeps HiGHS' scaled rows near 1.
_RECIPE_COMMAND_RAD_S = 0.01
#: A fraction below this is LP round-off, not a jet's share (HiGHS' tolerances are ~1e-9).
_FRACTION_FLOOR = 1e-9
#: Relative residual above which a channel's direction counts as unreachable.
_RESIDUAL_RTOL = 1e-6
#: "Nothing left" of a channel's on-time [s]: scaled deliveries leave float crumbs.
_TIME_EPS_S = 1e-12


def check_recipe_vehicle(recipe: ChannelRecipe, vehicle: Vehicle, *, what: str) -> None:
    """Refuse flying ``recipe`` on ``vehicle`` when its file is not the one it was solved for.

    ``what`` names the table for the message.  The check is by content (SHA-256): a copy of
    the vehicle file elsewhere is the same vehicle; an edited file is not.
    """
    if vehicle.sha256 != recipe.vehicle_sha256:
        raise InputError(
            f"{what}: a channel table solved for vehicle {recipe.vehicle} (sha256 "
            f"{recipe.vehicle_sha256[:12]}...), but {vehicle.ref} has sha256 "
            f"{vehicle.sha256[:12]}... (another vehicle, or the file changed since); regenerate "
            f"it with `rcsim lookup generate --vehicle {vehicle.label}`"
        )


def check_channel_jets_off(recipe_jets: int, jets_off) -> tuple:
    """``jets_off`` as sorted distinct jet numbers 1..``recipe_jets``; InputError otherwise.
    (A lost direction is the recipe's to find: it leaves that channel empty.)"""
    return jet_numbers(jets_off, recipe_jets)


def solve_recipe(vehicle: Vehicle, *, jets_off=()) -> ChannelRecipe:
    """The six channel recipes of a vehicle, without the jets ``jets_off`` (1-based).

    Parameters
    ----------
    vehicle : Vehicle, str or path
        The vehicle (resolved at the public edge: :meth:`Vehicle.load`).
    jets_off : sequence of int
        Jets the recipes may not use.

    Raises
    ------
    InputError
        A bad jet number, or a jet set that leaves an axis with no direction at all (no table
        can control it).
    """
    from rcsim.lookup.allocator_controller import allocator_controller

    d = vehicle.definition
    jets_off = check_channel_jets_off(d.n_jets, jets_off)
    # A recipe is a direction (shares of the longest jet, scaled each cycle): the LP relaxation,
    # with translation priced as it always was, whatever the profile's ``allocation`` is.
    ctl = allocator_controller(vehicle, jets_off=jets_off, allocation="propellant+translation")
    allocator = ctl.allocator
    command = CHANNEL_MAP * _RECIPE_COMMAND_RAD_S  # (6, 3)
    available = None
    if ctl.available is not None:
        available = np.broadcast_to(ctl.available, (len(CHANNELS), allocator.n))
    t, residual = allocator.allocate_relaxed(command, available)
    longest = t.max(axis=1)
    served = (np.linalg.norm(residual, axis=1) <= _RESIDUAL_RTOL * _RECIPE_COMMAND_RAD_S) & (
        longest > 0
    )
    frac = np.where(served[:, None], t / np.where(longest > 0, longest, 1.0)[:, None], 0.0)
    # LP round-off is not a share: a fraction within it of 0 or 1 is 0 or 1 (a balanced pair
    # is two jets fully on, not one at 1 - 1e-16).
    frac = np.where(frac < _FRACTION_FLOOR, 0.0, np.minimum(frac, 1.0))
    frac = np.where(frac > 1.0 - _FRACTION_FLOOR, 1.0, frac)
    rows = np.flatnonzero(served)
    frac[rows, frac[rows].argmax(axis=1)] = 1.0  # the longest is exactly 1, not 1 - 1e-16
    dead = [axis for a, axis in enumerate(AXES) if not served[2 * a : 2 * a + 2].any()]
    if dead:
        # Every direction lost is named (not only the first axis with none): the user fixes
        # the layout once.
        lost = [c for c, ok in zip(CHANNELS, served) if not ok]
        left = [c for c, ok in zip(CHANNELS, served) if ok]
        reach = (
            f"of the six axis directions it reaches only {', '.join(left)}"
            if left
            else "it reaches none of the six axis directions"
        )
        what = (
            f"no jet combination turns the vehicle toward {', '.join(lost)} ({reach}); no "
            "table can control " + " or ".join(dead)
        )
        if jets_off:
            raise InputError(
                f"{','.join(map(str, jets_off))}: with these jets of {vehicle.label} off, {what}",
                parameter="jets_off",
                value=list(jets_off),
            )
        raise InputError(f"{vehicle.label}: {what}", parameter="vehicle", value=vehicle.label)
    return ChannelRecipe(
        fractions=frac,
        accel_rad_s2=frac @ allocator.D.T,
        vehicle=vehicle.ref,
        vehicle_sha256=vehicle.sha256,
        jets_off=jets_off,
        min_on_s=d.min_on_s,
        source=f"solved for {vehicle.ref}",
    )


@dataclass
class ValveState:
    """Per-run, per-jet state of the channel delivery, ``(n_runs, n_jets)``.

    ``owed_s``: short shares not fired yet [s]; ``on_at_end``: the jet filled the last cycle
    (its next pulse continues a firing, which the valves never cut)."""

    owed_s: np.ndarray
    on_at_end: np.ndarray


class ChannelMap:
    """Channel on-times to jet on-times, every cycle, batched (module docstring: delivery).

    Parameters
    ----------
    fractions : ndarray, (6, n_jets)
        The recipe (:attr:`rcsim.models.tables.ChannelRecipe.fractions`).
    min_on_s : float
        Shortest new pulse the valves make [s].
    cycle_s : float
        Control cycle [s].
    min_pulse : str
        What a share shorter than ``min_on_s`` becomes: ``"accumulate"``, ``"round-up"`` or
        ``"drop"`` (the vehicle's profile, :mod:`rcsim.spacecraft.control_profile`).
    """

    def __init__(self, fractions, min_on_s: float, cycle_s: float, *, min_pulse: str):
        self.fractions = np.asarray(fractions, float)
        self.n_jets = self.fractions.shape[1]
        self._uses = (self.fractions > 0).astype(float)  # (6, n_jets)
        self.min_on_s = float(min_on_s)
        self.cycle_s = float(cycle_s)
        if min_pulse not in MIN_PULSE_POLICIES:
            raise InputError(
                f"min_pulse must be one of {', '.join(MIN_PULSE_POLICIES)}, got {min_pulse!r}"
            )
        self.min_pulse = min_pulse

    def initial(self, n_runs: int) -> ValveState:
        return ValveState(
            np.zeros((n_runs, self.n_jets)), np.zeros((n_runs, self.n_jets), dtype=bool)
        )

    def deliver(
        self, remaining_s: np.ndarray, valves: ValveState
    ) -> tuple[np.ndarray, np.ndarray, ValveState]:
        """Fire this cycle.

        Parameters
        ----------
        remaining_s : ndarray, (n_runs, 6)
            On-time left on each channel at the cycle's start [s].
        valves : ValveState

        Returns
        -------
        jet_on_s : ndarray, (n_runs, n_jets)
            Each jet's on-time this cycle [s], in ``[0, cycle]``.
        delivered_s : ndarray, (n_runs, 6)
            Channel time delivered this cycle [s] (``min(remaining, cycle)`` times the run's
            scale, 1 unless shared jets were asked for more than the cycle).
        valves : ValveState
        """
        cyc = self.cycle_s
        on = np.minimum(remaining_s, cyc)
        u = on @ self.fractions  # (n, J)
        peak = u.max(axis=1)
        scale = np.where(peak > cyc, cyc / np.where(peak > 0, peak, 1.0), 1.0)
        delivered = on * scale[:, None]
        u = np.minimum(u * scale[:, None], cyc)
        owed = valves.owed_s
        if self.min_on_s > 0 and self.min_pulse != "accumulate":
            # (a share under _TIME_EPS_S is a scaled delivery's float crumb, not a pulse)
            short = (u > _TIME_EPS_S) & (u < self.min_on_s) & ~valves.on_at_end
            u = np.where(u > _TIME_EPS_S, u, 0.0)
            fired = min(self.min_on_s, cyc) if self.min_pulse == "round-up" else 0.0
            u = np.where(short, fired, u)
        elif self.min_on_s > 0:
            left = (remaining_s - delivered) > _TIME_EPS_S  # (n, 6): the channel goes on
            asked_next = (left.astype(float) @ self._uses) > 0  # (n, J)
            short = (u > 0) & (u < self.min_on_s) & ~valves.on_at_end
            owed = owed + np.where(short, u, 0.0)
            due = short & (
                (owed >= self.min_on_s - _TIME_EPS_S)
                | (~asked_next & (owed >= 0.5 * self.min_on_s))
            )
            u = np.where(
                short, np.where(due, np.minimum(np.maximum(owed, self.min_on_s), cyc), 0.0), u
            )
            owed = np.where(due, 0.0, owed)
            # A jet that fires a full-size pulse anyway carries what it owes (within the cycle).
            carry = np.where((u > 0) & ~short, np.minimum(owed, cyc - u), 0.0)
            u = u + carry
            owed = np.where(asked_next, owed - carry, 0.0)
        on_at_end = u >= cyc * (1.0 - 1e-12)
        return u, delivered, ValveState(owed, on_at_end)


def axis_jets_of(recipe: ChannelRecipe, main: float = 0.5) -> np.ndarray:
    """(3, n_jets) bool: the jets a channel table fires *for* each axis -- those whose fraction
    in a channel of that axis is at least ``main`` (the trims that cancel another channel's
    coupling, a few percent, are not that axis's firings).  What campaign outcomes count as an
    axis's firing events for a channel table."""
    frac = recipe.fractions
    return np.stack([(frac[2 * a : 2 * a + 2] >= main).any(axis=0) for a in range(len(AXES))])
