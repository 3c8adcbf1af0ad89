"""Monte Carlo study of single-axis control under noisy sensors (Pittella & Sands 2023, §3).

The study is nondimensional: a rest-to-rest rotation of one unit of angle in one unit of
time (see :mod:`rcsim.lookup.single_axis`).  Each of the six architectures flies ``runs``
manoeuvres with

* RK4 at a fixed step ``dt = 0.01`` (the paper's Simulink ``ode4``), the control law
  evaluated at every stage, the controller's own states integrated with the plant;
* additive zero-mean Gaussian noise of variance ``noise_var`` on the measured angle and on
  the measured rate, independent, drawn once per step and held over it (a discrete noise
  source feeding continuous blocks, as in Simulink);
* a true inertia ``I ~ U[1 - spread, 1 + spread]`` per run, unknown to every controller
  (all of them are designed for ``I = 1``), entering as ``domega/dt = u / I``;
* the cost ``J = 1/2 int u^2 dt`` of the commanded control, integrated by the same RK4.

Run ``i`` draws from ``np.random.SeedSequence(seed, spawn_key=(i,))``, spawning one child
stream for inertia and one for sensor noise, so a run's draws depend on ``(seed, i)`` only.
All six architectures see the same draws (common random numbers), which sharpens their
comparison.  ``inertia_model="per-step"`` draws a new inertia every step instead; it is not
a physical model, it is our reconstruction of what the paper's Simulink model did (see
``docs/noisy-sensor.md``) and exists to compare with its Table 1.

The module is ~450 lines, over the usual ~400: configuration, draws, integrator and tables
are one study read top to bottom; its figure is in
:mod:`rcsim.analysis.apps.studies.noisy_sensor_plots` and its command line in
:mod:`rcsim.analysis.apps.cli.study`.

References
----------
A. Pittella and T. Sands, "Proposals for Surmounting Sensor Noises", Sensors 23 (2023)
3169: Section 3 (Monte Carlo set-up), Table 1 (summary), Table 2 (percent differences),
Figure 4 (scatter), Appendix B (MATLAB wrapper: ``std``, sigma ellipses).
"""

from __future__ import annotations

import importlib.metadata
import os
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from rcsim.analysis.apps.studies.noisy_sensor_plots import plot_scatter
from rcsim.analysis.engine.output import atomic_dir
from rcsim.lookup.single_axis import ARCHITECTURES, Architecture
from rcsim.models.errors import InputError
from rcsim.spacecraft.dispersions import run_generators
from rcsim.spacecraft.guards import human_bytes, memory_budget_bytes

#: Nondimensional manoeuvre time and the paper's ode4 step.
T_FINAL = 1.0
DT = 0.01

SUMMARY_COLUMNS = (
    "architecture",
    "theta_f",
    "sigma_theta",
    "omega_f",
    "sigma_omega",
    "J",
    "sigma_J",
    "wall_s",
)
PERCENT_COLUMNS = (
    "architecture",
    "theta_f",
    "sigma_theta",
    "omega_f",
    "sigma_omega",
    "J",
    "sigma_J",
)
OUTPUT_FILES = ("summary.csv", "percent.csv", "runs.parquet", "scatter.png")
#: The writer recorded in the output directory's marker (:mod:`rcsim.analysis.engine.output`).
OUTPUT_COMMAND = "study noisy-sensor"

#: Reference values smaller than this (in the nondimensional units of the table) are zero up
#: to round-off; a percent difference against them is undefined and written as empty.
PERCENT_REFERENCE_FLOOR = 1e-9

INERTIA_MODELS = ("per-run", "per-step")


@dataclass(frozen=True)
class StudyConfig:
    """Settings of one noisy-sensor study.

    Attributes
    ----------
    runs : int
        Monte Carlo runs per architecture (>= 2, so that a standard deviation exists).
    seed : int
        Root seed (>= 0).
    noise_var : float
        Variance of the additive sensor noise on angle and rate (nondimensional units
        squared); the paper uses 1e-4.
    inertia_spread : float
        Half-width ``F`` of the uniform inertia factor ``U[1 - F, 1 + F]``, in [0, 1).
    inertia_model : str
        ``"per-run"`` (one inertia per manoeuvre, the physical model) or ``"per-step"``
        (a new draw every step, our reconstruction of the paper's Simulink model).
    dt : float
        RK4 step (nondimensional time); must divide ``T_FINAL`` into whole steps.
    """

    runs: int = 1000
    seed: int = 0
    noise_var: float = 1e-4
    inertia_spread: float = 0.1
    inertia_model: str = "per-run"
    dt: float = DT

    def __post_init__(self):
        _check_config(self)

    @property
    def n_steps(self) -> int:
        """Number of RK4 steps from 0 to ``T_FINAL``."""
        return int(round(T_FINAL / self.dt))


def _check_config(cfg: StudyConfig) -> None:
    """Raise :class:`InputError` naming the parameter and value of the first bad setting."""
    if not _is_int(cfg.runs) or cfg.runs < 2:
        raise InputError(
            f"must be an integer >= 2 (a spread needs two runs), got {cfg.runs!r}",
            parameter="runs",
            value=cfg.runs,
        )
    if not _is_int(cfg.seed) or cfg.seed < 0:
        raise InputError(
            f"must be a non-negative integer, got {cfg.seed!r}", parameter="seed", value=cfg.seed
        )
    if not (np.isfinite(cfg.noise_var) and cfg.noise_var >= 0.0):
        raise InputError(
            f"must be a finite variance >= 0, got {cfg.noise_var!r}",
            parameter="noise_var",
            value=cfg.noise_var,
        )
    if not (np.isfinite(cfg.inertia_spread) and 0.0 <= cfg.inertia_spread < 1.0):
        raise InputError(
            f"must be in [0, 1) (a fraction of the inertia), got {cfg.inertia_spread!r}",
            parameter="inertia_spread",
            value=cfg.inertia_spread,
        )
    if cfg.inertia_model not in INERTIA_MODELS:
        raise InputError(
            f"must be one of {INERTIA_MODELS}, got {cfg.inertia_model!r}",
            parameter="inertia_model",
            value=cfg.inertia_model,
        )
    steps = T_FINAL / cfg.dt if cfg.dt > 0 else float("nan")
    if not (np.isfinite(steps) and abs(steps - round(steps)) < 1e-9 and round(steps) >= 1):
        raise InputError(
            f"must divide the manoeuvre time {T_FINAL} into whole steps, got {cfg.dt!r}",
            parameter="dt",
            value=cfg.dt,
        )
    _check_memory(cfg)


#: Bytes of one run's row in ``runs.parquet``'s frame, per architecture: 10 numeric columns,
#: two string references and pandas' overhead, rounded up (an estimate; the draws dominate).
RUN_ROW_BYTES = 256


def study_bytes(cfg: StudyConfig) -> int:
    """Memory a study holds at once [bytes]: its draws (float64) and the rows of ``runs``."""
    n_inertia = cfg.n_steps if cfg.inertia_model == "per-step" else 1
    per_run = 8 * (2 * (cfg.n_steps + 1) + n_inertia) + len(ARCHITECTURES) * RUN_ROW_BYTES
    return int(cfg.runs) * per_run


def _check_memory(cfg: StudyConfig) -> None:
    """Refuse up front a study that cannot fit, rather than dying in MemoryError."""
    budget = memory_budget_bytes()
    need = study_bytes(cfg)
    if budget is not None and need > budget:
        raise InputError(
            f"= {cfg.runs} needs about {human_bytes(need)} of memory, more than the "
            f"{human_bytes(budget)} allowed (half of this machine's memory): use fewer runs "
            f"(at most about {budget // (need // cfg.runs)})",
            parameter="runs",
            value=cfg.runs,
        )


def _is_int(value) -> bool:
    return isinstance(value, (int, np.integer)) and not isinstance(value, bool)


# --------------------------------------------------------------------------------------
# Random draws.
# --------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Draws:
    """Per-run random inputs, one row per run.

    Attributes
    ----------
    inertia : ndarray, shape (n_runs, n_inertia)
        Inertia factor (nondimensional, nominal 1); ``n_inertia`` is 1 (per-run model) or
        ``n_steps`` (per-step model).
    noise : ndarray, shape (n_runs, n_steps + 1, 2)
        Sensor noise on (angle, rate) for each step; the last step row is the reading at
        the final time, used only for the ``*_measured`` outputs.
    """

    inertia: np.ndarray
    noise: np.ndarray

    @property
    def n_runs(self) -> int:
        return self.noise.shape[0]

    @property
    def n_steps(self) -> int:
        return self.noise.shape[1] - 1


def draw_run(
    inertia_rng: np.random.Generator, noise_rng: np.random.Generator, cfg: StudyConfig
) -> tuple[np.ndarray, np.ndarray]:
    """Draw one run's inertia factors and sensor noise, each sequence in one call.

    Returns
    -------
    inertia : ndarray, shape (n_inertia,)
        Uniform in ``[1 - inertia_spread, 1 + inertia_spread]``.
    noise : ndarray, shape (n_steps + 1, 2)
        Zero-mean Gaussian, variance ``noise_var``, on (angle, rate).
    """
    n_inertia = cfg.n_steps if cfg.inertia_model == "per-step" else 1
    spread = cfg.inertia_spread
    inertia = inertia_rng.uniform(1.0 - spread, 1.0 + spread, size=n_inertia)
    noise = noise_rng.normal(0.0, np.sqrt(cfg.noise_var), size=(cfg.n_steps + 1, 2))
    return inertia, noise


def draw_runs(cfg: StudyConfig) -> Draws:
    """Draw inertia and sensor noise for every run of ``cfg``.

    Run ``i`` uses ``SeedSequence(seed, spawn_key=(i,))`` and its two spawned children
    (inertia, noise), so the draws of run ``i`` depend on ``(seed, i)`` only, not on
    ``cfg.runs``.  This is the only loop over runs; it costs about 40 microseconds per run
    (0.04 s for 1000 runs, shared by all architectures).

    Returns
    -------
    Draws
    """
    n_inertia = cfg.n_steps if cfg.inertia_model == "per-step" else 1
    inertia = np.empty((cfg.runs, n_inertia))
    noise = np.empty((cfg.runs, cfg.n_steps + 1, 2))
    for i in range(cfg.runs):  # per-run seeding, the campaigns' rule (one helper for both)
        inertia[i], noise[i] = draw_run(*run_generators(cfg.seed, i), cfg)
    return Draws(inertia=inertia, noise=noise)


# --------------------------------------------------------------------------------------
# Integration.
# --------------------------------------------------------------------------------------
def _derivative(
    arch: Architecture, t: float, y: np.ndarray, inv_inertia: np.ndarray, noise: np.ndarray
) -> np.ndarray:
    """Time derivative of the augmented state ``(theta, omega, J, controller states...)``.

    Parameters
    ----------
    y : ndarray, shape (n_runs, 3 + n_states)
    inv_inertia : ndarray, shape (n_runs,)
        ``1 / I`` held over the step.
    noise : ndarray, shape (n_runs, 2)
        Sensor noise on (angle, rate) held over the step.
    """
    u, state_dot = arch(t, y[:, 0] + noise[:, 0], y[:, 1] + noise[:, 1], y[:, 3:])
    dy = np.empty_like(y)
    dy[:, 0] = y[:, 1]
    dy[:, 1] = u * inv_inertia  # torque / inertia, not Eq. 6's literal I * u
    dy[:, 2] = 0.5 * u * u  # cost of the commanded control (Eq. 4)
    dy[:, 3:] = state_dot
    return dy


def simulate(
    arch: Architecture, draws: Draws, *, dt: float = DT, record: bool = False
) -> dict[str, np.ndarray]:
    """Fly one architecture over every run with classical RK4.

    Parameters
    ----------
    arch : Architecture
    draws : Draws
        Must hold ``round(T_FINAL / dt) + 1`` noise rows per run.
    dt : float
        Step (nondimensional time).
    record : bool
        Also return the angle and rate at every step boundary.

    Returns
    -------
    dict
        ``theta_f``, ``omega_f``, ``J`` (true final state and cost), ``theta_f_measured``,
        ``omega_f_measured`` (final sensor reading), each shape (n_runs,); with ``record``,
        ``t`` (n_steps + 1,), ``theta`` and ``omega`` (n_runs, n_steps + 1).
    """
    n_steps = draws.n_steps
    if n_steps != int(round(T_FINAL / dt)) or draws.inertia.shape[1] not in (1, n_steps):
        raise ValueError(
            f"draws for {n_steps} steps (inertia {draws.inertia.shape}) do not match dt = {dt}"
        )
    inv_inertia = 1.0 / draws.inertia
    y = np.zeros((draws.n_runs, 3 + arch.n_states))
    y[:, 3:] = arch.initial_state(draws.n_runs)
    history = [y[:, :2].copy()] if record else None
    for k in range(n_steps):
        t = k * dt  # time from the tick count, not accumulated, so the last step ends at 1
        w = inv_inertia[:, k % inv_inertia.shape[1]]
        n = draws.noise[:, k]
        k1 = _derivative(arch, t, y, w, n)
        k2 = _derivative(arch, t + 0.5 * dt, y + (0.5 * dt) * k1, w, n)
        k3 = _derivative(arch, t + 0.5 * dt, y + (0.5 * dt) * k2, w, n)
        k4 = _derivative(arch, (k + 1) * dt, y + dt * k3, w, n)
        y = y + (dt / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        if history is not None:
            history.append(y[:, :2].copy())
    out = {
        "theta_f": y[:, 0].copy(),
        "omega_f": y[:, 1].copy(),
        "J": y[:, 2].copy(),
        "theta_f_measured": y[:, 0] + draws.noise[:, -1, 0],
        "omega_f_measured": y[:, 1] + draws.noise[:, -1, 1],
    }
    if history is not None:
        hist = np.stack(history, axis=1)
        out.update(t=np.arange(n_steps + 1) * dt, theta=hist[..., 0], omega=hist[..., 1])
    return out


# --------------------------------------------------------------------------------------
# The study and its tables.
# --------------------------------------------------------------------------------------
@dataclass(frozen=True)
class StudyResult:
    """Outputs of :func:`run_study`.

    Attributes
    ----------
    runs : DataFrame
        One row per (architecture, run): ``architecture, run, inertia, theta_f, omega_f,
        J, theta_f_measured, omega_f_measured``.
    summary : DataFrame
        Paper Table 1 plus ``wall_s`` (seconds to simulate that architecture's runs).
    percent : DataFrame
        Paper Table 2: percent differences against open-loop optimal.
    draw_s : float
        Seconds spent drawing the random inputs (shared by all architectures).
    """

    runs: pd.DataFrame
    summary: pd.DataFrame
    percent: pd.DataFrame
    draw_s: float


def run_study(
    cfg: StudyConfig, architectures=ARCHITECTURES, *, measured: bool = False
) -> StudyResult:
    """Run the Monte Carlo for every architecture and build the tables.

    Parameters
    ----------
    cfg : StudyConfig
    architectures : sequence of Architecture
        Defaults to the paper's six; the first labelled "Open-loop optimal" is the
        reference of the percent table.
    measured : bool
        Summarise the final *sensor readings* instead of the true final state (our
        reconstruction of what the paper tabulates); ``runs`` always holds both.

    Returns
    -------
    StudyResult
    """
    start = time.perf_counter()
    draws = draw_runs(cfg)
    draw_s = time.perf_counter() - start
    frames, walls = [], {}
    for arch in architectures:
        start = time.perf_counter()
        result = simulate(arch, draws, dt=cfg.dt)
        walls[arch.label] = time.perf_counter() - start
        frames.append(_runs_frame(arch.label, cfg, draws, result))
    runs = pd.concat(frames, ignore_index=True)
    summary = summarize(runs, walls, measured=measured)
    return StudyResult(runs=runs, summary=summary, percent=percent_table(summary), draw_s=draw_s)


def _runs_frame(label: str, cfg: StudyConfig, draws: Draws, result: dict) -> pd.DataFrame:
    """One row per run: dispersed inertia, outcomes, and what reproduces the run."""
    return pd.DataFrame(
        {
            "architecture": label,
            "run": np.arange(draws.n_runs),
            "seed": cfg.seed,
            "inertia": draws.inertia.mean(axis=1),  # per-step model: the run's mean inertia
            **{
                key: result[key]
                for key in ("theta_f", "omega_f", "J", "theta_f_measured", "omega_f_measured")
            },
            "noise_var": cfg.noise_var,
            "inertia_spread": cfg.inertia_spread,
            "inertia_model": cfg.inertia_model,
            "code_version": _code_version(),
        }
    )


def _code_version() -> str:
    """Installed rcsim version (the work tree's commit is not known to the package)."""
    try:
        return importlib.metadata.version("rcsim")
    except importlib.metadata.PackageNotFoundError:
        return "unknown"


def summarize(
    runs: pd.DataFrame, walls: dict[str, float] | None = None, *, measured: bool = False
) -> pd.DataFrame:
    """Mean and standard deviation (``ddof=1``, MATLAB's ``std``) per architecture.

    Parameters
    ----------
    runs : DataFrame
        As in :class:`StudyResult`.
    walls : dict, optional
        Seconds per architecture label for the ``wall_s`` column (NaN if missing).
    measured : bool
        Use the final sensor readings instead of the true final state.

    Returns
    -------
    DataFrame
        Columns :data:`SUMMARY_COLUMNS`, rows in first-appearance order of ``runs``.
    """
    suffix = "_measured" if measured else ""
    walls = walls or {}
    rows = []
    for label, group in runs.groupby("architecture", sort=False):
        theta, omega, cost = (
            group[c].to_numpy() for c in (f"theta_f{suffix}", f"omega_f{suffix}", "J")
        )
        rows.append(
            {
                "architecture": label,
                "theta_f": theta.mean(),
                "sigma_theta": theta.std(ddof=1),
                "omega_f": omega.mean(),
                "sigma_omega": omega.std(ddof=1),
                "J": cost.mean(),
                "sigma_J": cost.std(ddof=1),
                "wall_s": walls.get(label, float("nan")),
            }
        )
    return pd.DataFrame(rows, columns=list(SUMMARY_COLUMNS))


def percent_table(summary: pd.DataFrame, reference: str = "Open-loop optimal") -> pd.DataFrame:
    """Percent differences ``100 (x - x_ref) / x_ref`` against ``reference`` (paper Table 2).

    Entries whose reference magnitude is below :data:`PERCENT_REFERENCE_FLOOR` are NaN:
    a percent of (round-off) zero is undefined.  (The paper's sigma_J column, whose open-loop
    reference is exactly 0, is in fact ``100 sigma_J``.)

    Returns
    -------
    DataFrame
        Columns :data:`PERCENT_COLUMNS`.
    """
    ref_rows = summary[summary["architecture"] == reference]
    if ref_rows.empty:
        raise InputError(f"percent table: no reference architecture {reference!r} in summary")
    ref = ref_rows.iloc[0]
    out = pd.DataFrame({"architecture": summary["architecture"]})
    for col in PERCENT_COLUMNS[1:]:
        r = float(ref[col])
        values = summary[col].to_numpy(dtype=float)
        out[col] = 100.0 * (values - r) / r if abs(r) >= PERCENT_REFERENCE_FLOOR else np.nan
    return out


# --------------------------------------------------------------------------------------
# Output.
# --------------------------------------------------------------------------------------
def write_outputs(result: StudyResult, out_dir: str | Path, *, overwrite: bool = False) -> Path:
    """Write the four outputs into ``out_dir`` atomically
    (:func:`rcsim.analysis.engine.output.atomic_dir`).

    Parameters
    ----------
    result : StudyResult
    out_dir : path
        Created with its parents; an existing directory is replaced only if it holds an
        earlier study's outputs and ``overwrite`` is true (see :mod:`rcsim.analysis.engine.output`).
    overwrite : bool

    Returns
    -------
    Path
        ``out_dir``, absolute.
    """
    with atomic_dir(out_dir, OUTPUT_COMMAND, overwrite=overwrite) as tmp:
        result.summary.to_csv(tmp / "summary.csv", index=False, float_format="%.6g")
        result.percent.to_csv(tmp / "percent.csv", index=False, float_format="%.4g")
        result.runs.to_parquet(tmp / "runs.parquet", index=False)
        plot_scatter(result.runs, tmp / "scatter.png")
    return Path(os.path.abspath(out_dir))


def format_summary(summary: pd.DataFrame) -> str:
    """The summary table as fixed-width text for the terminal."""
    return summary.to_string(index=False, float_format=lambda v: f"{v:.4f}")
