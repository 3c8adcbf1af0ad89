"""The DAI study: continuous-torque attitude control (Wilt & Sands 2022; Smeresky & Rizzo 2020).

Scenarios (:data:`SCENARIOS`):

* ``wilt_yaw30`` -- 001 Sec. 3.1 / Table 6: 30 deg yaw, FFD+FB vs hybrid FFD+FB+DAI;
* ``wilt_yaw30_disturbed`` -- 001 Sec. 3.2 / Table 7: the same with gravity gradient and drag;
* ``wilt_yaw100_damage`` -- 001 Sec. 3.3 / Tables 8-9: 100 deg yaw, disturbances, and the
  sudden inertia change of App. A.2 at t = 8 s (the controllers keep the nominal model);
* ``smeresky_yaw30`` -- 002 Sec. 4 / Table 2: 30 deg yaw with FFD, FB and FFD+FB at 0.001 s;
* ``smeresky_yaw30_coarse`` -- 002 Sec. 4.1: FFD+FB at 0.01 s, the time-step comparison.

Every scenario flies through the three CMGs of 002 (``rcsim.spacecraft.continuous.cmg``) in
MuJoCo (RK4 at the paper's step).  Each (scenario, method) is one batch: the nominal vehicle
(the papers' deterministic case, row ``run = -1`` of ``montecarlo.csv`` and the figures of
merit of ``summary.csv``) plus ``runs`` Monte Carlo runs over ``rcsim/models/dai/dispersions.csv``
(true inertia scale per axis, sensor noise on the measured Euler angles).  Run ``i`` draws from
``SeedSequence(seed, spawn_key=(i,))``, spawned into an inertia and a noise stream; every method
sees the same draws.

Figures of merit (the columns of 001 Tables 6-9 and 002 Table 2): the tracking error is the
signed yaw error ``psi - psi_d`` [deg] sampled every step over the whole run; its mean and
standard deviation; the control effort ``int |u| dt`` of the delivered torque [N m s]; the wall
time of the batch [s]; plus the final and largest principal-angle error [deg].  001's "control
effort" column equals its run times (SOURCES.md); ours is a torque integral, and the wall
time is its own column.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pandas as pd

from rcsim.analysis.apps.studies.dai_plots import plot_scenario, plot_theta_hat, plot_timestep
from rcsim.analysis.engine.output import atomic_dir, check_out_dir
from rcsim.lookup.continuous.controllers import (
    DAI_LAWS,
    INTEGRAL_LAW,
    ContinuousController,
    ControllerConfig,
)
from rcsim.lookup.continuous.trajectory import SinusoidalTrajectory
from rcsim.models.dai import (
    PaperSetup,
    load_cmg,
    load_damage,
    load_dispersions,
    load_environment,
    load_setup,
)
from rcsim.models.errors import InputError
from rcsim.spacecraft.continuous.cmg import CmgArray
from rcsim.spacecraft.continuous.disturbances import Disturbances
from rcsim.spacecraft.continuous.kinematics import angle_between, euler321_from_quat
from rcsim.spacecraft.continuous.plant import ContinuousHistory, ContinuousPlant, fly
from rcsim.spacecraft.dispersions import MAX_SEED

OUTPUT_COMMAND = "study dai"
SUMMARY_COLUMNS = (
    "scenario",
    "method",
    "mean_tracking_error_deg",
    "tracking_error_std_deg",
    "control_effort_n_m_s",
    "wall_time_s",
    "final_error_deg",
    "max_error_deg",
    "mc_runs",
    "mc_mean_abs_tracking_error_deg",
    "mc_tracking_error_std_deg",
    "mc_max_error_p95_deg",
    "cmg_singular_steps",
)


@dataclass(frozen=True)
class Scenario:
    """One paper case: which paper's vehicle and gains, the maneuver, what is switched on."""

    paper: str
    yaw_deg: float
    methods: tuple[str, ...]
    disturbances: bool = False
    damage: bool = False
    timestep_s: float | None = None  # None: the paper's


SCENARIOS = {
    "wilt_yaw30": Scenario("wilt2022", 30.0, ("ffd+fb", *DAI_LAWS)),
    "wilt_yaw30_disturbed": Scenario("wilt2022", 30.0, ("ffd+fb", *DAI_LAWS), disturbances=True),
    "wilt_yaw100_damage": Scenario(
        "wilt2022", 100.0, ("ffd+fb", *DAI_LAWS), disturbances=True, damage=True
    ),
    "smeresky_yaw30": Scenario("smeresky2020", 30.0, ("ffd", "fb", "ffd+fb")),
    "smeresky_yaw30_coarse": Scenario("smeresky2020", 30.0, ("ffd+fb",), timestep_s=0.01),
}


@dataclass
class MethodResult:
    """One (scenario, method) batch: per-run metrics and the nominal run's history."""

    scenario: str
    method: str
    runs: pd.DataFrame
    history: ContinuousHistory
    reference: dict
    wall_s: float


def _setup(scn: Scenario, period_scale: float) -> PaperSetup:
    setup = load_setup(scn.paper)
    return replace(
        setup,
        quiescent_s=setup.quiescent_s * period_scale,
        maneuver_s=setup.maneuver_s * period_scale,
        observation_s=setup.observation_s * period_scale,
        timestep_s=scn.timestep_s or setup.timestep_s,
    )


def _draws(
    inertia: np.ndarray, n_steps: int, runs: int, seed: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """True inertia (1 + runs, 3, 3), angle noise (1 + runs, n_steps, 3), scales (1 + runs, 3).

    Row 0 is the nominal vehicle without noise; row ``1 + i`` is Monte Carlo run ``i``.
    """
    disp = load_dispersions()
    scale_d, noise_d = disp["inertia_scale"], disp["angle_noise"]
    scales = np.ones((1 + runs, 3))
    noise = np.zeros((1 + runs, n_steps, 3))
    for i in range(runs):  # draws once per run at set-up, never in the flight loop
        inertia_ss, noise_ss = np.random.SeedSequence(seed, spawn_key=(i,)).spawn(2)
        scales[1 + i] = np.random.default_rng(inertia_ss).uniform(
            scale_d.nominal - scale_d.bound, scale_d.nominal + scale_d.bound, 3
        )
        noise[1 + i] = np.random.default_rng(noise_ss).normal(
            noise_d.nominal, noise_d.bound, (n_steps, 3)
        )
    root = np.sqrt(scales)
    true = inertia[None] * root[:, :, None] * root[:, None, :]  # S^1/2 J S^1/2
    return true, noise, scales


def _metrics(hist: ContinuousHistory, ref: dict) -> pd.DataFrame:
    err_rad = np.angle(np.exp(1j * (euler321_from_quat(hist.q_BN)[..., 2] - ref["euler"][:, 2])))
    err = np.degrees(err_rad)
    ang = np.degrees(angle_between(hist.q_BN, ref["q"][None]))
    dt = hist.t_s[1] - hist.t_s[0]
    return pd.DataFrame(
        {
            "mean_tracking_error_deg": err.mean(axis=1),
            "tracking_error_std_deg": err.std(axis=1),
            "control_effort_n_m_s": np.linalg.norm(hist.u_act_B, axis=-1).sum(axis=1) * dt,
            "final_error_deg": ang[:, -1],
            "max_error_deg": ang.max(axis=1),
            "cmg_singular_steps": (
                hist.cmg_singular.sum(axis=1) if hist.cmg_singular is not None else 0
            ),
        }
    )


def run_method(
    name: str, method: str, *, runs: int = 0, seed: int = 0, period_scale: float = 1.0
) -> MethodResult:
    """Fly one method of scenario ``name``: the nominal vehicle plus ``runs`` Monte Carlo runs."""
    scn = SCENARIOS[name]
    setup = _setup(scn, period_scale)
    traj = SinusoidalTrajectory(
        (0.0, 0.0, 0.0), (0.0, 0.0, np.radians(scn.yaw_deg)), setup.quiescent_s, setup.maneuver_s
    )
    n_steps = int(round(setup.duration_s / setup.timestep_s))
    true_j, noise, scales = _draws(setup.inertia_B, n_steps, runs, seed)
    cfg = ControllerConfig(
        method,
        setup.inertia_B,
        setup.pdi_gains,
        setup.observer_gains,
        setup.timestep_s,
        setup.dai_memory_s,
        setup.dai_gain_s3,
    )
    plant = ContinuousPlant(true_j, timestep_s=setup.timestep_s)
    dist = Disturbances(load_environment()) if scn.disturbances else None
    damage = load_damage() if scn.damage else None
    if damage is not None and period_scale != 1.0:
        damage = replace(damage, time_s=damage.time_s * period_scale)
    wall0 = time.perf_counter()
    hist = fly(
        plant,
        ContinuousController(cfg, traj),
        setup.duration_s,
        cmg=CmgArray(load_cmg()),
        disturbances=dist,
        damage=damage,
        angle_noise=noise if runs else None,
    )
    wall = time.perf_counter() - wall0
    ref = traj.sample(hist.t_s)
    table = _metrics(hist, ref)
    table.insert(0, "run", np.arange(-1, runs))
    for axis, col in enumerate(("inertia_scale_x", "inertia_scale_y", "inertia_scale_z")):
        table.insert(1 + axis, col, scales[:, axis])
    table.insert(0, "method", method)
    table.insert(0, "scenario", name)
    return MethodResult(name, method, table, hist, ref, wall)


def _summary_row(res: MethodResult) -> dict:
    nominal = res.runs.iloc[0]
    mc = res.runs.iloc[1:]
    return {
        "scenario": res.scenario,
        "method": res.method,
        "mean_tracking_error_deg": nominal["mean_tracking_error_deg"],
        "tracking_error_std_deg": nominal["tracking_error_std_deg"],
        "control_effort_n_m_s": nominal["control_effort_n_m_s"],
        "wall_time_s": res.wall_s,
        "final_error_deg": nominal["final_error_deg"],
        "max_error_deg": nominal["max_error_deg"],
        "mc_runs": len(mc),
        "mc_mean_abs_tracking_error_deg": (
            mc["mean_tracking_error_deg"].abs().mean() if len(mc) else np.nan
        ),
        "mc_tracking_error_std_deg": mc["tracking_error_std_deg"].mean() if len(mc) else np.nan,
        "mc_max_error_p95_deg": mc["max_error_deg"].quantile(0.95) if len(mc) else np.nan,
        "cmg_singular_steps": int(nominal["cmg_singular_steps"]),
    }


#: The scenario whose FFD+FB run has nothing to reject (no disturbance, no damage, no noise,
#: the controller's model exact): its tracking error is the closed loop's integration and
#: sampling floor, below which a difference between methods is not a measured effect.
FLOOR_SCENARIO = "wilt_yaw30"
#: A baseline within this factor of the floor is "at the noise floor".
FLOOR_FACTOR = 10.0
IMPROVEMENT_COLUMNS = (
    "scenario",
    "method",
    "learning_law",
    "mean_tracking_error_pct",
    "tracking_error_std_pct",
    "control_effort_pct",
    "paper_table",
    "paper_mean_pct",
    "paper_std_pct",
    "paper_effort_pct",
    "noise_floor_deg",
    "baseline_at_noise_floor",
    "note",
)


def learning_law(method: str) -> str:
    """What a DAI reading learns and where it goes, with its gain or memory as flown
    (``rcsim/models/dai/parameters.csv``)."""
    setup = load_setup("wilt2022")
    if method == INTEGRAL_LAW:
        return f"{DAI_LAWS[method]}, g = {setup.dai_gain_s3:g} s^3"
    return f"{DAI_LAWS[method]}, memory {setup.dai_memory_s:g} s"


def _pct(base: float, other: float) -> float:
    base, other = abs(base), abs(other)
    return 100.0 * (base - other) / base if base > 0 else np.nan


def improvement_table(summary: pd.DataFrame, paper=None) -> pd.DataFrame:
    """001 Table 9 for each DAI reading: percent improvement over FFD+FB per 001 scenario.

    ``100 (FB - DAI) / FB`` of |mean tracking error|, its standard deviation and the control
    effort (positive: DAI is better), beside the paper's own figure for that scenario
    (computed from its Tables 6-8 the way its Table 9 is; ``rcsim/models/dai``).  A row whose
    FFD+FB baseline (mean or std) is within :data:`FLOOR_FACTOR` of the integration floor
    (the FFD+FB errors of :data:`FLOOR_SCENARIO`) is marked ``baseline_at_noise_floor``: its
    percentages compare numbers at rounding level and say nothing about the methods.
    """
    from rcsim.models.dai import load_paper_figures

    paper = load_paper_figures() if paper is None else paper
    ref = {(r.scenario, r.method): r for r in paper if r.table in (6, 7, 8)}
    floor = np.nan
    nominal = summary[(summary["scenario"] == FLOOR_SCENARIO) & (summary["method"] == "ffd+fb")]
    if len(nominal):
        floor = float(
            max(
                abs(nominal["mean_tracking_error_deg"].iloc[0]),
                nominal["tracking_error_std_deg"].iloc[0],
            )
        )
    rows = []
    for scn, group in summary.groupby("scenario", sort=False):
        by = group.set_index("method")
        if "ffd+fb" not in by.index:
            continue
        base = by.loc["ffd+fb"]
        for method in (m for m in DAI_LAWS if m in by.index):
            dai = by.loc[method]
            row = {"scenario": scn, "method": method, "learning_law": learning_law(method)}
            for col, key in (
                ("mean_tracking_error_pct", "mean_tracking_error_deg"),
                ("tracking_error_std_pct", "tracking_error_std_deg"),
                ("control_effort_pct", "control_effort_n_m_s"),
            ):
                row[col] = _pct(base[key], dai[key])
            p_base, p_dai = ref.get((scn, "ffd+fb")), ref.get((scn, "ffd+fb+dai"))
            if p_base is not None and p_dai is not None:
                row.update(
                    paper_table=int(p_base.table),
                    paper_mean_pct=_pct(p_base.mean, p_dai.mean),
                    paper_std_pct=_pct(p_base.std, p_dai.std),
                    paper_effort_pct=_pct(p_base.effort, p_dai.effort),
                )
            low = min(abs(base["mean_tracking_error_deg"]), base["tracking_error_std_deg"])
            at_floor = bool(np.isfinite(floor) and low <= FLOOR_FACTOR * floor)
            row.update(
                noise_floor_deg=floor,
                baseline_at_noise_floor=at_floor,
                note=(
                    f"FFD+FB baseline {low:.2g} deg is within {FLOOR_FACTOR:g}x the "
                    f"integration floor {floor:.2g} deg: the percentages compare "
                    "rounding, not methods"
                    if at_floor
                    else ""
                ),
            )
            rows.append(row)
    return pd.DataFrame(rows, columns=list(IMPROVEMENT_COLUMNS))


#: Bytes a flight records per run and step (rcsim/spacecraft/continuous/plant.py ``fly``: attitude,
#: rate, commanded, delivered and disturbance torques, CMG determinant and flag, the DAI
#: telemetry and its stacking copy, the angle noise), rounded up.
BYTES_PER_RUN_STEP = 320


def _check_memory(names: tuple[str, ...], runs: int, period_scale: float) -> None:
    """Refuse a study whose histories (all kept until the figures are drawn) would not fit in
    half the machine's memory, before anything flies."""
    from rcsim.spacecraft.guards import memory_budget_bytes

    budget = memory_budget_bytes()
    if budget is None:
        return
    steps = 0
    for name in names:
        setup = _setup(SCENARIOS[name], period_scale)
        steps += len(SCENARIOS[name].methods) * int(round(setup.duration_s / setup.timestep_s))
    need = steps * (runs + 1) * BYTES_PER_RUN_STEP
    if need > budget:
        most = max(0, budget // (steps * BYTES_PER_RUN_STEP) - 1)
        raise InputError(
            f"must be at most {most} on this machine for these scenarios (their "
            f"histories would need {need / 2**30:.1f} GiB, over half the "
            f"memory, {budget / 2**30:.1f} GiB), got {runs}",
            parameter="runs",
            value=runs,
        )


def run_dai_study(
    out_dir: str | Path,
    *,
    scenarios: tuple[str, ...] | None = None,
    runs: int = 0,
    seed: int = 0,
    period_scale: float = 1.0,
    overwrite: bool = False,
    progress=None,
) -> pd.DataFrame:
    """Fly the DAI scenarios and write ``out_dir``.

    Writes ``summary.csv`` (one row per scenario and method: :data:`SUMMARY_COLUMNS`),
    ``improvement.csv`` (001 Table 9), ``montecarlo.csv`` (one row per run), one time-history
    figure per scenario (``<scenario>.png``), ``<scenario>_theta_hat.png`` for the DAI
    scenarios and ``timestep.png`` (002 Fig. 8).  All or nothing (:func:`atomic_dir`).

    Parameters
    ----------
    out_dir : path
    scenarios : tuple of str, optional
        Names from :data:`SCENARIOS`; default all.
    runs : int
        Monte Carlo runs per (scenario, method), >= 0, besides the nominal one.
    seed : int
        Root seed, >= 0.
    period_scale : float
        Multiplies the quiescent, maneuver and observation periods (and the damage time);
        1 is the papers', smaller values are for smoke tests.  In (0, 1].
    overwrite : bool
        Replace an earlier ``rcsim study dai`` output.
    progress : callable, optional
        Called with ``"scenario/method"`` before each batch.

    Returns
    -------
    DataFrame
        The summary.
    """
    names = tuple(SCENARIOS) if scenarios is None else tuple(scenarios)
    unknown = [n for n in names if n not in SCENARIOS]
    if unknown or not names:
        got = ", ".join(unknown) or "none"
        raise InputError(
            f"must be among {', '.join(SCENARIOS)}, got {got}", parameter="scenarios", value=unknown
        )
    if isinstance(runs, bool) or not isinstance(runs, (int, np.integer)) or runs < 0:
        raise InputError(f"must be an integer >= 0, got {runs!r}", parameter="runs", value=runs)
    if (
        isinstance(seed, bool)
        or not isinstance(seed, (int, np.integer))
        or not 0 <= seed <= MAX_SEED
    ):
        raise InputError(
            f"must be an integer in 0..{MAX_SEED} (2^63 - 1), got {seed!r}",
            parameter="seed",
            value=seed,
        )
    if not (0 < period_scale <= 1):
        raise InputError(
            f"must be in (0, 1], got {period_scale}", parameter="period_scale", value=period_scale
        )
    _check_memory(names, runs, period_scale)
    check_out_dir(out_dir, OUTPUT_COMMAND, overwrite=overwrite)  # before minutes of flying
    results: dict[str, list[MethodResult]] = {}
    for name in names:
        for method in SCENARIOS[name].methods:
            if progress is not None:
                progress(f"{name}/{method}")
            results.setdefault(name, []).append(
                run_method(name, method, runs=runs, seed=seed, period_scale=period_scale)
            )
    summary = pd.DataFrame(
        [_summary_row(r) for rs in results.values() for r in rs], columns=SUMMARY_COLUMNS
    )
    with atomic_dir(out_dir, OUTPUT_COMMAND, overwrite=overwrite) as tmp:
        summary.to_csv(tmp / "summary.csv", index=False, float_format="%.6g")
        improvement_table(summary).to_csv(tmp / "improvement.csv", index=False, float_format="%.4g")
        pd.concat([r.runs for rs in results.values() for r in rs]).to_csv(
            tmp / "montecarlo.csv", index=False, float_format="%.6g"
        )
        for name, rs in results.items():
            plot_scenario(name, rs, tmp / f"{name}.png")
            if any(r.method in DAI_LAWS for r in rs):
                plot_theta_hat(name, rs, tmp / f"{name}_theta_hat.png")
        fine = [r for r in results.get("smeresky_yaw30", []) if r.method == "ffd+fb"]
        coarse = results.get("smeresky_yaw30_coarse", [])
        if fine and coarse:
            plot_timestep(coarse[0], fine[0], tmp / "timestep.png")
    return summary
