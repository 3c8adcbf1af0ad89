"""Physics-aware derived factors: what an analyst thinks in, computed from the recorded inputs.

A campaign records ~55 raw inputs per run (mass, CG, three inertias, and per jet thrust, tilt
and azimuth: 7 + 3 n for a vehicle of n jets, 55 for the paper's 16).  The jets act in
groups: Table 2 of Gambone (``rcsim/models/data/table2_jet_map.csv``)
gives, for each axis and direction, the two jets that fire about it.  For every run and every
group ``G`` (axis ``a`` in roll/pitch/yaw, direction ``pos``/``neg``) this module derives

``authority_{a}_{dir}_rad_s2``
    Control authority: the torque of the group's jets about the run's dispersed CG (dispersed
    thrust and pointing), component along axis ``a`` and signed so that positive means "in the
    group's direction", divided by the run's inertia about ``a`` -- the angular acceleration
    the group gives [rad/s^2] (the inertia about ``a`` is the tensor's diagonal entry: with
    products of inertia a single-axis figure, as Gambone's Fig. 15 plots it).
``thrust_{a}_{dir}_n``
    Total thrust of the group [N].
``imbalance_{a}_{dir}_n``
    Only for a group of exactly two jets (the paper's pairs, Table 2): thrust of the pair's
    first jet minus its second [N].  A pair is built so that its two torques about the other
    axes cancel at equal thrust; the difference is what the other axes feel when it fires.
    A group of three or more jets (a canted layout's: every jet whose torque about ``a`` has
    the group's sign) has no such meaning -- its jets do not fire together as a set, and no
    one difference of two of them is what the other axes feel -- so it gets no imbalance
    factor (its authority and pointing loss already carry the thrust and pointing draws).
``pointing_loss_{a}_{dir}``
    ``1 - torque / torque with nominal pointing`` about ``a`` (same thrust and CG): the share
    of authority lost to jet misalignment alone (dimensionless).

and, when the campaign's cases are rate commands (``rate-NN``; or damping, ``damp-NN``), the
same three quantities **in the firing direction** of each case: ``authority_{a}_fire_rad_s2``,
``thrust_{a}_fire_n``, ``pointing_loss_{a}_fire`` take the group that fires toward the
commanded rate change (for an axis with no commanded change, the mean of both groups, which
hold it at rest).  Vehicles come back from the recorded inputs through the runs table's
owner (:func:`rcsim.analysis.engine.runs_table.vehicles_from_runs`, with the simulator's own
pointing rule) and torques from :func:`rcsim.spacecraft.vehicle.run_parameters.torque_per_jet_B`.

and, when the campaign recorded dispersed modes (``mode_<name>_coupled_freq_hz``, a vehicle
file's ``*_3sigma`` keys of its ``[[slosh]]`` / ``[[appendage]]`` blocks), for each mode

``mode_{name}_freq_ratio``
    The mode's coupled frequency over the controller's firing frequency in that run
    (:func:`mode_factors`): ``mode_<name>_coupled_freq_hz / f_fire`` with ``f_fire`` [Hz] the
    firing events per second of the run's busiest axis, ``max_a firings_<a> / T`` (``T`` the
    run's flown duration, ``60 pulses / pulses_per_min``).  Near 1 (or a small integer) the
    jets' limit cycle drives the mode at resonance.  The firing events count a pair (any jets
    starting together about the axis) as one impulse, the one the structure feels;
    ``pulses_per_min`` counts each jet, overstating it by the group's size (2 to 4 jets fire at
    once on a canted vehicle), and one axis's limit cycle, not the sum over axes, is the
    periodic forcing.  A run with no firing (or no outcome) has no such frequency: its ratio
    is placed beyond every run's that has one (their largest + 1), as the effects' "does not
    apply" values are.

A campaign that flew a vehicle file (its spec's ``vehicle``) is analysed with that vehicle's
model, and its groups come from the vehicle's own jet matrix: the jets whose nominal torque
about axis ``a`` has the group's sign (:func:`rcsim.spacecraft.vehicle.authority.torque_signs`;
for the paper's vehicle this is Table 2 exactly).  A canted jet belongs to a group of every
axis it torques.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from rcsim.analysis.engine.runs_table import axis_inertia, input_names, vehicles_from_runs
from rcsim.spacecraft.vehicle import Vehicle
from rcsim.spacecraft.vehicle.model import AXES
from rcsim.spacecraft.vehicle.run_parameters import torque_per_jet_B

_DIRS = ((1, "pos"), (-1, "neg"))


def physics_factors(
    runs: pd.DataFrame,
    vehicle: Vehicle,
    fire_sign: np.ndarray | None = None,
    jet_map: np.ndarray | None = None,
) -> pd.DataFrame:
    """Derived factors of every run (see the module docstring).

    Parameters
    ----------
    runs : DataFrame
        Holds the recorded inputs (:func:`rcsim.analysis.engine.runs_table.input_names` of the
        vehicle's jets).
    vehicle : rcsim.spacecraft.vehicle.Vehicle
        The vehicle the runs flew: its model, nominal parameters and torque signs.
    fire_sign : ndarray of int (n, 3), optional
        Per run and axis, the sign of the commanded rate change (0: none); adds the
        firing-direction factors.
    jet_map : ndarray of int (n_jets, 3), optional
        Torque signs per jet and axis; default the vehicle's own
        (:attr:`rcsim.spacecraft.vehicle.Vehicle.axis_signs`).

    Returns
    -------
    DataFrame, one row per run, index aligned with ``runs``.
    """
    model, nominal = vehicle.model, vehicle.nominal(1)
    jet_map = vehicle.axis_signs if jet_map is None else jet_map
    missing = [c for c in input_names(nominal.n_jets) if c not in runs.columns]
    if missing:
        raise ValueError(
            f"runs lack the recorded inputs {missing[:3]}{' ...' if len(missing) > 3 else ''}"
        )
    if fire_sign is not None:
        fire_sign = np.asarray(fire_sign)
    # Blocks of runs: the vehicles' per-jet arrays and the pointing's temporaries are ~3 KB a
    # run (~700 MB for 250,000 runs at once); each run's arithmetic is its own, so the blocks
    # change no value.
    parts = [
        _block_factors(
            runs.iloc[i : i + FACTOR_BLOCK_RUNS],
            None if fire_sign is None else fire_sign[i : i + FACTOR_BLOCK_RUNS],
            model,
            nominal,
            jet_map,
        )
        for i in range(0, max(len(runs), 1), FACTOR_BLOCK_RUNS)
    ]
    return parts[0] if len(parts) == 1 else pd.concat(parts)


#: Runs whose factors are computed at once (:func:`physics_factors`).
FACTOR_BLOCK_RUNS = 16_384


def _block_factors(runs, fire_sign, model, nominal, jet_map) -> pd.DataFrame:
    """:func:`physics_factors` of one block of runs (index aligned with ``runs``)."""
    dispersed, straight = vehicles_from_runs(runs, nominal)
    torque = torque_per_jet_B(dispersed, model)  # (n, n_jets, 3) [N m]
    torque_nom = torque_per_jet_B(straight, model)
    inertia = axis_inertia(runs)  # about each body axis (the tensor's diagonal)
    thrust = dispersed.thrust_n
    cols: dict[str, np.ndarray] = {}
    per_group = {}
    for a, axis in enumerate(AXES):
        for sign, dname in _DIRS:
            jets = np.flatnonzero(jet_map[:, a] == sign)
            if jets.size == 0:
                continue
            t_disp = sign * torque[:, jets, a].sum(axis=1)
            t_nom = sign * torque_nom[:, jets, a].sum(axis=1)
            auth = t_disp / inertia[:, a]
            group_thrust = thrust[:, jets].sum(axis=1)
            loss = 1.0 - t_disp / t_nom
            cols[f"authority_{axis}_{dname}_rad_s2"] = auth
            cols[f"thrust_{axis}_{dname}_n"] = group_thrust
            if jets.size == 2:  # a pair only (module docstring)
                cols[f"imbalance_{axis}_{dname}_n"] = thrust[:, jets[0]] - thrust[:, jets[1]]
            cols[f"pointing_loss_{axis}_{dname}"] = loss
            per_group[(a, sign)] = (auth, group_thrust, loss)
    if fire_sign is not None:
        for a, axis in enumerate(AXES):
            if (a, 1) not in per_group or (a, -1) not in per_group:
                continue
            pos, neg = per_group[(a, 1)], per_group[(a, -1)]
            s = fire_sign[:, a]
            for k, name in enumerate(
                (
                    f"authority_{axis}_fire_rad_s2",
                    f"thrust_{axis}_fire_n",
                    f"pointing_loss_{axis}_fire",
                )
            ):
                cols[name] = np.where(
                    s > 0, pos[k], np.where(s < 0, neg[k], 0.5 * (pos[k] + neg[k]))
                )
    return pd.DataFrame(cols, index=runs.index)


#: Outcome columns :func:`mode_factors` reads (besides ``firings_<axis>``).
_PULSE_COLUMNS = ("pulses", "pulses_per_min")


def firing_frequency_hz(runs: pd.DataFrame) -> np.ndarray | None:
    """Firing events per second of each run's busiest axis, ``max_a firings_<a> / T`` with the
    flown duration ``T = 60 pulses / pulses_per_min`` [s] (module docstring); NaN for a run
    that never fired (``T`` unknown, the frequency 0) or has no outcome.  None when the table
    lacks those columns."""
    cols = [f"firings_{a}" for a in AXES]
    if not all(c in runs.columns for c in (*cols, *_PULSE_COLUMNS)):
        return None
    events = runs[cols].to_numpy(float).max(axis=1)
    pulses = runs["pulses"].to_numpy(float)
    per_min = runs["pulses_per_min"].to_numpy(float)
    with np.errstate(divide="ignore", invalid="ignore"):
        duration_s = 60.0 * pulses / per_min
        f = events / duration_s
    return np.where(np.isfinite(f) & (f > 0), f, np.nan)


def mode_factors(runs: pd.DataFrame) -> tuple[pd.DataFrame, int]:
    """``mode_<name>_freq_ratio`` of every mode whose coupled frequency ``runs`` records
    (module docstring), and how many runs had no firing frequency (placed beyond the largest
    ratio).  No columns when the table records no mode or lacks the firing columns."""
    modes = [
        c[: -len("_coupled_freq_hz")]
        for c in runs.columns
        if c.startswith("mode_") and c.endswith("_coupled_freq_hz")
    ]
    f_fire = firing_frequency_hz(runs) if modes else None
    if f_fire is None:
        return pd.DataFrame(index=runs.index), 0
    unknown = ~np.isfinite(f_fire)
    cols = {}
    for mode in modes:
        ratio = runs[f"{mode}_coupled_freq_hz"].to_numpy(float) / f_fire
        known = ratio[np.isfinite(ratio)]
        fill = float(known.max()) + 1.0 if known.size else 0.0
        cols[f"{mode}_freq_ratio"] = np.where(np.isfinite(ratio), ratio, fill)
    return pd.DataFrame(cols, index=runs.index), int(unknown.sum())


def fire_signs(case_names) -> np.ndarray | None:
    """Sign of the commanded rate change per axis of every run, from its case name.

    ``rate-NN`` (Table 3 case NN flown from rest to its rate) fires toward the rate;
    ``damp-NN`` (from the case rate to rest) fires against it.  Returns ``(n, 3)`` ints, or
    None when any case is not such a rate case (maneuvers and holds have no single firing
    direction).
    """
    from rcsim.models.tables import load_rate_cases

    table = load_rate_cases()
    numbers = {int(c): k for k, c in enumerate(table.case)}
    codes, names = pd.factorize(
        pd.Series(np.asarray(case_names, dtype=object)), use_na_sentinel=False
    )
    signs = []
    for name in names:
        kind, _, num = str(name).partition("-")
        if kind not in ("rate", "damp") or not num.isdigit() or int(num) not in numbers:
            return None
        sign = np.sign(np.asarray(table.rate_cmd[numbers[int(num)]])).astype(int)
        signs.append(sign if kind == "rate" else -sign)
    # One row per distinct case, taken per run (a list of 10^6 small arrays was ~1 GB).
    return np.stack(signs)[codes] if signs else np.zeros((0, 3), int)
