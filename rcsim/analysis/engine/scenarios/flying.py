"""Fly the named scenarios, measure them, and compare the two controllers.

:func:`fly_scenario` flies a :class:`~rcsim.analysis.engine.scenarios.catalog.PaperScenario` in one
batch; :func:`scenario_metrics` measures it (final errors, firings, propellant, the time from
which attitude and rate stay settled); :func:`compare_controllers` flies every scenario with
both controllers.
"""

from __future__ import annotations

import sys

import numpy as np
import pandas as pd

from rcsim.analysis.engine.flight import fly_batch
from rcsim.analysis.engine.scenarios.catalog import PaperScenario, all_scenarios, get_scenario
from rcsim.lookup.registry import CONTROLLERS, make_controller
from rcsim.models.errors import InputError
from rcsim.spacecraft.control_profile import ControlProfile
from rcsim.spacecraft.simulation import History
from rcsim.spacecraft.vehicle import Vehicle
from rcsim.spacecraft.vehicle.run_parameters import RunParameters

#: Rows of the comparison: the paper's controller first, then the phase-plane baseline.
COMPARISON_ORDER = tuple(sorted(CONTROLLERS, key=lambda name: name != "lookup"))


def build_controller(
    scenario: PaperScenario, controller: str, vehicle: Vehicle, *, table=None, **lookup_overrides
):
    """The controller for ``scenario`` on ``vehicle`` with the scenario's options applied.

    Parameters
    ----------
    controller : {"lookup", "phase-plane"}
    table : path, optional
        Lookup table CSV (lookup only); default the packaged table.
    **lookup_overrides
        Extra :class:`LookupParams` fields (they win over the scenario's).
    """
    return make_controller(
        controller,
        vehicle,
        table=table,
        lookup_options={**scenario.lookup_options, **lookup_overrides},
        phase_plane_options=scenario.phase_plane_options,
    )


def check_scenario_vehicle(scenario: PaperScenario, vehicle: Vehicle) -> None:
    """Refuse to fly ``scenario`` on ``vehicle`` when a run's disturbance torque exceeds the
    jets' largest torque about an axis (:meth:`Vehicle.disturbance_problem`, the campaign's
    and :func:`rcsim.fly`'s rule): no controller could hold it, and the flight would only show
    that."""
    for run in scenario.runs:
        dist = np.asarray(run.disturbance_n_m, float)
        problem = vehicle.disturbance_problem(dist)
        if problem:
            raise InputError(
                f"scenario {scenario.name}: disturbance_n_m: {problem} (got {dist.tolist()} N m)"
            )


def fly_scenario(
    scenario: PaperScenario,
    controller: str = "lookup",
    *,
    table=None,
    vehicle: Vehicle | None = None,
    params: RunParameters | None = None,
    controller_obj=None,
    **lookup_overrides,
) -> History:
    """Fly every run of ``scenario`` in one batch (default: the nominal vehicle per run).

    Parameters
    ----------
    vehicle : Vehicle, optional
        The vehicle flown; default the paper's (the scenarios are the paper's).
    params : RunParameters, optional
        One vehicle per run (``scenario.n_runs``), e.g. an off-nominal one.
    controller_obj : Controller, optional
        Use this controller instead of building one.
    """
    vehicle = Vehicle.load(vehicle)
    params = vehicle.nominal(scenario.n_runs) if params is None else params
    ctl = controller_obj or build_controller(
        scenario, controller, vehicle, table=table, **lookup_overrides
    )
    return fly_batch(scenario.runs, params, ctl, vehicle=vehicle)


def settle_tolerances(control: ControlProfile) -> tuple[float, float]:
    """Settling tolerances shared by both controllers in the comparison, from the vehicle's
    profile: attitude [rad], the edge of the lookup controller's hold region (maneuver limit +
    no-firing band: 0.6 + 0.1 deg, Table 4 and Figs 17-18, for the paper's vehicle; it also
    contains the phase plane's 0.25 deg deadband), and rate [rad/s], the lookup controller's
    rate deadband (0.06 deg/s, Table 4's rate error limit)."""
    return control.maneuver_limit_rad + control.maneuver_band_rad, control.rate_deadband_rad_s


def settled_time(history: History, *, att_tol_rad: float, rate_tol_rad_s: float) -> np.ndarray:
    """Per run, the time from which the total attitude error stays within ``att_tol_rad``
    *and* every axis's rate error within ``rate_tol_rad_s`` to the end [s]; NaN if the run
    ends outside.  Shape (n_runs,).

    Reported as ``att_rate_settled_time_s``.  Not the campaigns' ``rate_settled_time_s``
    (rate only, against the campaign's failure threshold) nor table generation's
    ``settle_after_firing_s`` (counted from the end of the firing).
    """
    att = np.concatenate([history.att_err_B, history.final.att_err_B[:, None]], axis=1)
    rate = np.concatenate([history.rate_err_B, history.final.rate_err_B[:, None]], axis=1)
    t = np.append(history.t_s, history.final.t_s)
    outside = (np.linalg.norm(att, axis=2) > att_tol_rad) | (
        np.abs(rate).max(axis=2) > rate_tol_rad_s
    )
    # Index of the last sample outside (-1 if none); settled at the next sample.
    last = np.where(outside.any(axis=1), outside.shape[1] - 1 - np.argmax(outside[:, ::-1], 1), -1)
    settled = last < outside.shape[1] - 1
    return np.where(settled, t[np.minimum(last + 1, len(t) - 1)], np.nan)


def scenario_metrics(
    history: History, scenario: PaperScenario, control: ControlProfile
) -> pd.DataFrame:
    """Per run: final errors, firings, propellant, settled time (degrees at this boundary),
    the settling tolerances from the flown vehicle's profile ``control``
    (:func:`settle_tolerances`).

    Columns: ``run``, ``label``, ``final_att_err_deg`` (total angle), ``final_rate_err_deg_s``
    (largest axis), ``firings`` (jet firings started), ``on_time_s``, ``propellant_kg``,
    ``att_rate_settled_time_s`` (:func:`settled_time`; NaN: ends outside its tolerances),
    ``failed`` (the simulation failed), ``reason`` (why, '' if it did not).
    """
    final = history.final
    prop = history.propulsion
    att_tol, rate_tol = settle_tolerances(control)
    return pd.DataFrame(
        {
            "run": np.arange(history.n_runs),
            "label": [r.name for r in scenario.runs],
            "final_att_err_deg": np.degrees(np.linalg.norm(final.att_err_B, axis=1)),
            "final_rate_err_deg_s": np.degrees(np.abs(final.rate_err_B).max(axis=1)),
            "firings": prop.firings.sum(axis=1),
            "on_time_s": prop.on_time_s.sum(axis=1),
            "propellant_kg": history.propellant_kg,
            "att_rate_settled_time_s": settled_time(
                history, att_tol_rad=att_tol, rate_tol_rad_s=rate_tol
            ),
            "failed": history.failed,
            "reason": list(history.reason),
        }
    )


def summarize(metrics: pd.DataFrame) -> dict:
    """One row for a scenario: worst final errors, totals, longest settled time."""
    settle = metrics["att_rate_settled_time_s"]
    return {
        "runs": int(len(metrics)),
        "final_att_err_deg": float(metrics["final_att_err_deg"].max()),
        "final_rate_err_deg_s": float(metrics["final_rate_err_deg_s"].max()),
        "firings": int(metrics["firings"].sum()),
        "propellant_kg": float(metrics["propellant_kg"].sum()),
        "att_rate_settled_time_s": float(settle.max()) if settle.notna().all() else float("nan"),
        "failed": int(metrics["failed"].sum()),
    }


def compare_controllers(
    names=None, *, table=None, progress: bool | None = None, vehicle: Vehicle | None = None
) -> pd.DataFrame:
    """Fly each scenario with both controllers; one row per (scenario, controller).

    Parameters
    ----------
    vehicle : Vehicle, optional
        The vehicle flown; default the paper's (the scenarios are the paper's).
    names : sequence of str, optional
        Scenario names (default: all).
    table : path, optional
        Lookup table for the lookup controller.
    progress : bool, optional
        A progress bar on stderr (flights done, flights/s, ETA); default only when stderr is a
        terminal, so CI logs stay quiet.
    """
    from tqdm import tqdm

    names = list(names or all_scenarios())
    scenarios = [get_scenario(name) for name in names]  # unknown names fail before any flight
    vehicle = Vehicle.load(vehicle)
    rows = []
    with tqdm(
        total=len(scenarios) * len(COMPARISON_ORDER),
        unit="flight",
        desc="scenario compare",
        file=sys.stderr,
        disable=not (sys.stderr.isatty() if progress is None else progress),
        dynamic_ncols=True,
    ) as bar:
        for scn in scenarios:
            for ctl in COMPARISON_ORDER:
                bar.set_postfix_str(f"{scn.name} / {ctl}")
                hist = fly_scenario(
                    scn, ctl, table=table if ctl == "lookup" else None, vehicle=vehicle
                )
                rows.append(
                    {
                        "scenario": scn.name,
                        "controller": ctl,
                        **summarize(scenario_metrics(hist, scn, vehicle.control)),
                    }
                )
                bar.update(1)
    return pd.DataFrame(rows)


def comparison_markdown(frame: pd.DataFrame, control: ControlProfile) -> str:
    """The comparison as a markdown table (deg, deg/s, kg, s); ``control``: the flown
    vehicle's profile, whose settling tolerances the note states."""
    head = (
        "| scenario | controller | final att. err [deg] | final rate err [deg/s] | "
        "firings | propellant [kg] | settled from [s] |\n|---|---|---|---|---|---|---|\n"
    )
    lines = []
    for r in frame.itertuples(index=False):
        t = r.att_rate_settled_time_s
        settle = "not settled" if np.isnan(t) else f"{t:.2f}"
        lines.append(
            f"| {r.scenario} | {r.controller} | {r.final_att_err_deg:.3f} | "
            f"{r.final_rate_err_deg_s:.4f} | {r.firings} | {r.propellant_kg:.4f} | {settle} |"
        )
    att_tol, rate_tol = settle_tolerances(control)
    note = (
        f"\nSettled from: the time after which the total attitude error stays within "
        f"{np.degrees(att_tol):.4g} deg and every axis's rate error within "
        f"{np.degrees(rate_tol):.4g} deg/s to the end of the flight "
        "(column `att_rate_settled_time_s` of comparison.csv).\n"
    )
    return head + "\n".join(lines) + "\n" + note
