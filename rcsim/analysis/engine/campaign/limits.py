"""Physical ranges of campaign spec values: what the physics or the paper allows, and why.

A value of the right type can still be absurd (a dispersion scale of 1e300, a hold disturbance
of 1e300 N m, an initial rate of 1e6 deg/s); :mod:`~rcsim.analysis.engine.campaign.spec` refuses
those with
the range computed here and its reason, before anything is flown.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from rcsim.models.errors import InputError
from rcsim.spacecraft.control_profile import MAX_VALIDATED_RATE_DEG_S as MAX_INITIAL_RATE_DEG_S
from rcsim.spacecraft.control_profile import VALIDATED_STEP_S

if TYPE_CHECKING:
    from rcsim.spacecraft.vehicle import Vehicle

# Largest initial body rate of a hold [deg/s] (norm) at the validated physics step, and that
# step [s]: the flight-software profile's rate bound (rcsim.spacecraft.control_profile says
# why); a vehicle with another physics step gets the rate that turns it as far per step
# (:func:`vehicle_limits`).

# A chunk's simulation records every cycle of every run (rcsim.spacecraft.simulation.History,
# sized by rcsim.spacecraft.guards.history_bytes).  Long runs get smaller chunks so that one
# chunk's record stays under this budget [bytes]: a 500 s maneuver in a 256-run chunk would
# otherwise hold over 700 MB.
HISTORY_BUDGET_BYTES = 192 * 2**20


def max_duration_s(
    measured: bool = False,
    delivered: bool = False,
    *,
    n_jets: int,
    cycle_s: float,
    n_modes: int = 0,
) -> float:
    """Longest run a campaign flies [s]: one run's per-cycle record, for a vehicle of
    ``n_jets`` jets and ``n_modes`` mode coordinates (slosh, appendages) on a control cycle of
    ``cycle_s`` [s], within a chunk's budget (``measured``, ``delivered``: with the records of
    imperfect sensors and of valve timing or faults, :func:`rcsim.spacecraft.guards.
    history_bytes`), as :func:`rcsim.analysis.engine.campaign.chunk.max_chunk_runs` counts it."""
    from rcsim.spacecraft.guards import history_bytes

    # history_bytes(1, 1): one run's record of one cycle, with its share of the time column.
    one = history_bytes(1, 1, measured, delivered, n_jets=n_jets, n_modes=n_modes)
    return (HISTORY_BUDGET_BYTES // one) * cycle_s


def vehicle_limits(vehicle: Vehicle) -> dict:
    """Ranges the nominal ``vehicle`` gives: computed from the vehicle flown, never another's.

    Returns
    -------
    dict
        ``torque_n_m``: (3,) largest torque the jets give about each body axis (all jets of
        one sign on the axis firing, nominal thrust; the smaller of the two senses) [N m].
        ``three_sigma``: dispersion name -> (upper bound of its 3-sigma in SI, reason)
        (:func:`rcsim.spacecraft.dispersions.three_sigma_bounds`).  ``inertia_B``: (3, 3) the
        nominal inertia tensor about the CG in B [kg m^2], which limits the inertia 3-sigma
        values as a whole (:func:`rcsim.spacecraft.dispersions.inertia_scale_limit`).
    """
    from rcsim.spacecraft.dispersions import three_sigma_bounds
    from rcsim.spacecraft.propellant import full_inertia
    from rcsim.spacecraft.vehicle.model import BODY, jet_geometry_B

    model = vehicle.model
    nom = vehicle.nominal(1)
    authority = vehicle.axis_torque_n_m()
    pos_B, _ = jet_geometry_B(model)
    tensor = full_inertia(nom.inertia_B, model.body_iquat[model.body(BODY).id])[0]
    return {
        "torque_n_m": authority,
        "three_sigma": three_sigma_bounds(
            nom.mass_kg[0], np.diag(tensor), nom.thrust_n[0], nom.cg_B[0], pos_B
        ),
        "inertia_B": tensor,
        "initial_rate_deg_s": MAX_INITIAL_RATE_DEG_S
        * (VALIDATED_STEP_S / vehicle.definition.timestep_s),
    }


def check_three_sigma(
    frame, scale: float, overrides: dict, source: str, sigma_keys: dict, limits: dict
) -> None:
    """Every 3-sigma times ``scale`` must be below its physical bound, and the inertia 3-sigma
    values together must keep the dispersed tensor a rigid body's
    (:func:`rcsim.spacecraft.dispersions.inertia_scale_limit`).

    Names the override key when an override is out of range, else ``dispersions.scale`` with
    the largest scale these 3-sigma values allow.

    Parameters
    ----------
    frame : DataFrame
        Dispersion table (``name``, ``three_sigma`` in SI) after overrides, before scale.
    scale : float
    overrides : dict
        Spec key (``thrust_n``) -> the override's value as written.
    source : str
        The spec file, for the message.
    sigma_keys : dict
        Spec key -> (dispersion name, factor from the key's unit to SI).
    limits : dict
        :func:`vehicle_limits` of the vehicle flown.
    """
    from rcsim.spacecraft.dispersions import (
        INERTIA_ENTRIES,
        INERTIA_RULE,
        inertia_scale_limit,
        largest_inertia_sigma,
        second_moment_slack,
    )

    bounds = limits["three_sigma"]
    keys = {row: key for key, (row, _) in sigma_keys.items()}
    entries = [
        (keys[n], float(v), *bounds[n])
        for n, v in zip(frame["name"], frame["three_sigma"])
        if n in bounds
    ]
    bad = [(key, v, bound, why) for key, v, bound, why in entries if not v * scale < bound]
    units = {"kg": "kg", "m": "m", "m2": "kg m^2", "n": "N", "deg": "deg"}
    unit = lambda key: units[key.rsplit("_", 1)[-1]]  # noqa: E731
    for key, _v, bound, why in bad:
        if key in overrides:
            factor = sigma_keys[key][1]
            raise InputError(
                f"{source}: dispersions.three_sigma.{key}: times scale {scale:g} it must be "
                f"below {bound / factor:.4g} {unit(key)}, {why}: a 3-sigma draw must stay "
                f"physical (got {overrides[key]!r})"
            )
    inertia = {
        n: float(v) for n, v in zip(frame["name"], frame["three_sigma"]) if n in INERTIA_ENTRIES
    }
    tensor_scale = inertia_scale_limit(limits["inertia_B"], inertia)
    tensor_bad = scale > 0 and not scale < tensor_scale
    if tensor_bad:
        slack = second_moment_slack(limits["inertia_B"])
        named = [keys[n] for n in INERTIA_ENTRIES if keys[n] in overrides and inertia.get(n, 0) > 0]
        if named:
            # The override that weighs most, named with the largest value it could take with
            # the others as they are -- when some value would do; else the scale is to blame.
            key = max(named, key=lambda k: INERTIA_ENTRIES[sigma_keys[k][0]] * overrides[k])
            most = largest_inertia_sigma(limits["inertia_B"], inertia, sigma_keys[key][0], scale)
            if most > 0:
                raise InputError(
                    f"{source}: dispersions.three_sigma.{key}: "
                    + INERTIA_RULE.format(slack=slack)
                    + f"; with the other values and scale {scale:g} it must be below "
                    f"{most:.4g} kg m^2 (got {overrides[key]!r})"
                )
    if not bad and not tensor_bad:
        return
    per_entry = min((bound / v for _, v, bound, _ in entries if v > 0), default=math.inf)
    largest = min(per_entry, tensor_scale)
    if tensor_scale <= per_entry:
        raise InputError(
            f"{source}: dispersions.scale: must be < {largest:.4g} with these 3-sigma values: "
            + INERTIA_RULE.format(slack=second_moment_slack(limits["inertia_B"]))
            + f" (got {scale!r})"
        )
    key, v, bound, why = min(bad, key=lambda e: e[2] / e[1])
    factor = sigma_keys[key][1]
    raise InputError(
        f"{source}: dispersions.scale: must be < {largest:.4g} with these 3-sigma values: "
        f"every 3-sigma times scale must stay below its physical bound, and the 3-sigma of "
        f"{key} would be {v * scale / factor:.4g} {unit(key)}, at least {why} "
        f"({bound / factor:.4g}) (got {scale!r})"
    )
