"""Physical ranges of campaign spec values: what the physics or the paper allows, and why.

A value of the right type can still be absurd (a dispersion scale of 1e300, a hold disturbance
of 1e300 N m, an initial rate of 1e6 deg/s); :mod:`~analysis.engine.campaign.spec` refuses those
with
the range computed here and its reason, before anything is flown.
"""

from __future__ import annotations

import math

import numpy as np

from models.errors import InputError

# Largest initial body rate of a hold [deg/s] (norm): docs/convergence.md validates the 40 ms
# RK4 physics step with a torque-free tumble at ~3 deg/s, 10x the paper's largest commanded
# rate (0.3 deg/s, Table 3); beyond it the step's accuracy is not established.
MAX_INITIAL_RATE_DEG_S = 3.0

# A chunk's simulation records every cycle of every run (spacecraft.simulation.History,
# sized by spacecraft.guards.history_bytes).  Long runs get smaller chunks so that one
# chunk's record stays under this budget [bytes]: a 500 s maneuver in a 256-run chunk would
# otherwise hold over 700 MB.
HISTORY_BUDGET_BYTES = 192 * 2**20


def max_duration_s(measured: bool = False, delivered: bool = False) -> float:
    """Longest run a campaign flies [s]: one run's per-cycle record within a chunk's budget
    (``measured``, ``delivered``: with the records of imperfect sensors and of valve timing or
    faults, :func:`spacecraft.guards.history_bytes`)."""
    from models.tables import CONTROL_CYCLE_S
    from spacecraft.guards import history_bytes

    # history_bytes(1, 1): one run's record of one cycle, with its share of the time column;
    # campaigns fly the paper's cycle (CampaignSpec.cycle_s).
    return (HISTORY_BUDGET_BYTES // history_bytes(1, 1, measured, delivered)) * CONTROL_CYCLE_S


_LIMITS: dict = {}


def physical_limits() -> dict:
    """Ranges the nominal vehicle gives (computed once from the packaged model).

    Returns
    -------
    dict
        ``torque_n_m``: (3,) largest torque the jets give about each body axis (all jets of
        one sign on the axis firing, nominal thrust) [N m].  ``three_sigma``: Table 5 name ->
        (upper bound of its 3-sigma in the table's unit, reason): the nominal mass, moments
        and thrust (a 3-sigma draw must stay positive), 90 deg of thruster tilt (a jet must
        still push forwards), and the largest distance along x from the nominal CG to a jet
        (the CG must stay inside the jet layout).
    """
    if not _LIMITS:
        from spacecraft.vehicle import VehicleParams, jet_geometry_B, load_model, torque_per_jet_B

        model = load_model()
        nom = VehicleParams.nominal(1, model)
        torque = torque_per_jet_B(nom, model)[0]  # (16, 3)
        authority = np.minimum(
            np.where(torque > 0, torque, 0).sum(axis=0),
            -np.where(torque < 0, torque, 0).sum(axis=0),
        )
        pos_B, _ = jet_geometry_B(model)
        extent = float(np.max(np.abs(pos_B[:, 0] - nom.cg_B[0, 0])))
        _LIMITS.update(
            torque_n_m=authority,
            three_sigma={
                "mass": (float(nom.mass_kg[0]), "the nominal mass"),
                "ixx": (float(nom.inertia_B[0, 0]), "the nominal Ixx"),
                "iyy": (float(nom.inertia_B[0, 1]), "the nominal Iyy"),
                "izz": (float(nom.inertia_B[0, 2]), "the nominal Izz"),
                "thrust": (float(nom.thrust_n.min()), "the nominal thrust"),
                "thruster_angle": (
                    math.pi / 2,
                    "a 90 deg tilt (the jet would no longer push forwards)",
                ),
                "cg_x": (extent, "the distance from the nominal CG to the farthest jet along x"),
            },
        )
    return _LIMITS


def check_three_sigma(frame, scale: float, overrides: dict, source: str, sigma_keys: dict) -> None:
    """Every 3-sigma times ``scale`` must be below its physical bound (:func:`physical_limits`).

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
        Spec key -> (Table 5 name, factor from the key's unit to SI).
    """
    limits = physical_limits()["three_sigma"]
    keys = {row: key for key, (row, _) in sigma_keys.items()}
    entries = [
        (keys[n], float(v), *limits[n])
        for n, v in zip(frame["name"], frame["three_sigma"])
        if n in limits
    ]
    bad = [(key, v, bound, why) for key, v, bound, why in entries if not v * scale < bound]
    if not bad:
        return
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
    largest = min(bound / v for _, v, bound, _ in entries if v > 0)
    key, v, bound, why = min(bad, key=lambda e: e[2] / e[1])
    factor = sigma_keys[key][1]
    raise InputError(
        f"{source}: dispersions.scale: must be < {largest:.4g} with these 3-sigma values: "
        f"every 3-sigma times scale must stay below its physical bound, and the 3-sigma of "
        f"{key} would be {v * scale / factor:.4g} {unit(key)}, at least {why} "
        f"({bound / factor:.4g}) (got {scale!r})"
    )
