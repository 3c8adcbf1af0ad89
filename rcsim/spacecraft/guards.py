"""What the closed loop refuses before it flies, and how it names a run whose physics diverged.

* :func:`check_cycle`: a controller timing its firings on a control cycle other than the
  valves' (``PropulsionParams.cycle_s``) is refused -- it would fire for the wrong times and
  count the wrong firings, silently.
* :func:`check_history_memory`: a history that cannot fit in memory is refused up front, with
  the bytes it needs and what to do instead, rather than dying in ``MemoryError`` (or in the
  operating system's out-of-memory killer) after the set-up.
* :func:`warning_reasons`: the failure reason of a run whose MuJoCo warning counters rose
  (see :mod:`rcsim.spacecraft.simulation`, "Failures").
* :func:`invalid_runs`: per run, why its parameters cannot be flown (non-finite, non-physical,
  a tensor no rigid body has); such runs are flown nominal and reported failed.

Imports ``rcsim.models`` and :mod:`rcsim.spacecraft.vehicle`.
"""

from __future__ import annotations

import math
import os

import mujoco
import numpy as np

from rcsim.models.errors import InputError
from rcsim.spacecraft.vehicle.run_parameters import RunParameters


def history_bytes_per_run_cycle(n_jets: int) -> int:
    """Bytes a history records per run per control cycle: ``q_BN`` (4), ``omega_B``,
    ``att_err_B``, ``rate_err_B`` (3 each) and ``on_time_s`` (one per jet), float64."""
    return (4 + 3 * 3 + int(n_jets)) * 8


def check_cycle(controller: object, cycle_s: float) -> None:
    """Raise InputError if ``controller.cycle_s`` is not ``cycle_s`` [s], the flown vehicle's.

    Every controller states its cycle (:class:`rcsim.spacecraft.simulation.Controller`).
    Equal to a relative 1e-9: both come from the same profile or the same user number;
    anything else is a different clock, not rounding.
    """
    ctl_cycle = getattr(controller, "cycle_s", None)
    if ctl_cycle is None:
        raise InputError(
            f"{type(controller).__name__} has no cycle_s: a controller states the control "
            "cycle it assumes (build it from the vehicle's profile, vehicle.control.cycle_s)"
        )
    if not math.isclose(float(ctl_cycle), float(cycle_s), rel_tol=1e-9, abs_tol=0.0):
        raise InputError(
            f"{type(controller).__name__}.cycle_s = {ctl_cycle} s differs from the vehicle's "
            f"control cycle {cycle_s} s: build the controller from the vehicle's profile "
            "(vehicle.control.cycle_s)"
        )


def memory_budget_bytes() -> int | None:
    """Largest history a flight may record [bytes]: half the machine's physical memory.

    Half, because the caller usually copies or converts a history once (a frame, a file) and
    the machine runs other things too.  None where the platform does not report its memory
    (no ``os.sysconf``); then no history is refused.
    """
    try:
        physical = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (AttributeError, ValueError, OSError):
        return None
    return physical // 2 if physical > 0 else None


#: Extra bytes per run per cycle when the sensors are not perfect: ``meas_att_err_B`` and
#: ``meas_rate_err_B`` (3 float64 each).
MEASURED_BYTES_PER_RUN_CYCLE = 6 * 8


def history_bytes(
    n_runs: int,
    n_cycles: int,
    measured: bool = False,
    delivered: bool = False,
    *,
    n_jets: int,
) -> int:
    """Bytes of the per-cycle record of ``n_runs`` runs of a vehicle of ``n_jets`` jets over
    ``n_cycles`` cycles (with ``t_s``; ``measured``: with the measured errors of imperfect
    sensors; ``delivered``: with the delivered on-times, ``delivered_s``, one float64 per jet,
    kept when valve timing, faults or a thrust profile apply)."""
    per_run = (
        history_bytes_per_run_cycle(n_jets)
        + (MEASURED_BYTES_PER_RUN_CYCLE if measured else 0)
        + (int(n_jets) * 8 if delivered else 0)
    )
    return int(n_cycles) * (int(n_runs) * per_run + 8)


def human_bytes(n: float) -> str:
    """``n`` bytes in binary units, three significant digits: ``'182 TiB'``."""
    for unit in ("B", "KiB", "MiB", "GiB", "TiB"):
        if n < 1024:
            return f"{n:.3g} {unit}"
        n /= 1024
    return f"{n:.3g} PiB"


def check_history_memory(
    n_runs: int,
    n_cycles: int,
    duration_s: float,
    measured: bool = False,
    delivered: bool = False,
    *,
    n_jets: int,
) -> None:
    """Raise InputError if recording ``n_cycles`` cycles of ``n_runs`` runs of a vehicle of
    ``n_jets`` jets exceeds :func:`memory_budget_bytes` (``measured``, ``delivered``: the
    optional records of :func:`history_bytes`)."""
    budget = memory_budget_bytes()
    need = history_bytes(n_runs, n_cycles, measured, delivered, n_jets=n_jets)
    if budget is not None and need > budget:
        raise InputError(
            f"= {duration_s:g} s is {n_cycles} control cycles; recording them for "
            f"{n_runs} run(s) needs {human_bytes(need)} ({need} bytes, "
            f"{history_bytes_per_run_cycle(n_jets)} bytes per run per cycle), more than the "
            f"{human_bytes(budget)} allowed (half of this machine's memory): shorten the "
            f"flight, or split the runs into smaller batches",
            parameter="duration_s",
            value=duration_s,
        )


def warning_reasons(
    warning: np.ndarray, candidates: np.ndarray, t0_s: float, t1_s: float
) -> dict[int, str]:
    """Failure reasons of the candidate runs whose MuJoCo warning counters are nonzero.

    Parameters
    ----------
    warning : ndarray of int, (n_runs, mjNWARNING, 2)
        Per-run ``MjData.warning`` as ``(lastinfo, number)``, counted since the last reset.
    candidates : ndarray of bool, (n_runs,)
        Runs to look at (those not failed already).
    t0_s, t1_s : float
        Span of simulated time in which the counters may have risen [s].

    Returns
    -------
    dict
        Run index -> reason: the warning's name, when, and MuJoCo's text, e.g.
        ``"MuJoCo mjWARN_BADQACC at t = 0.16 .. 0.2 s: Nan, Inf or huge value in QACC at DOF 0.
        The simulation is unstable."``.
    """
    if not np.count_nonzero(warning[:, :, 1]):  # the usual cycle, without numpy's slow any()
        return {}
    warned = (warning[:, :, 1] > 0).any(axis=1) & candidates
    when = f"t = {t0_s:.6g} s" if t1_s == t0_s else f"t = {t0_s:.6g} .. {t1_s:.6g} s"
    reasons = {}
    for i in np.flatnonzero(warned):  # only the runs that just failed
        kind = int(np.flatnonzero(warning[i, :, 1] > 0)[0])
        info = int(warning[i, kind, 0])
        reasons[int(i)] = (
            f"MuJoCo {mujoco.mjtWarning(kind).name} at {when}: {mujoco.mju_warningText(kind, info)}"
        )
    return reasons


def invalid_runs(params: RunParameters) -> list[str]:
    """Per run, why its parameters cannot be simulated ('' when they can)."""
    reasons = [""] * params.n_runs
    checks = (
        ("mass_kg", params.mass_kg[:, None], lambda v: v > 0),
        ("cg_B", params.cg_B, lambda v: np.ones_like(v, bool)),
        ("inertia_B", params.inertia_B, lambda v: v > 0),
        ("thrust_n", params.thrust_n, lambda v: v >= 0),
        ("jet_dir_S", params.jet_dir_S.reshape(params.n_runs, -1), lambda v: np.ones_like(v, bool)),
    )
    for name, values, ok in checks:
        with np.errstate(invalid="ignore"):
            bad = ~(np.isfinite(values) & ok(values))
        for i in np.flatnonzero(bad.any(axis=1)):
            if not reasons[i]:
                reasons[i] = f"invalid parameter {name}: {values[i].tolist()}"
    if params.iquat is not None:
        with np.errstate(invalid="ignore"):
            unit = np.abs(np.linalg.norm(params.iquat, axis=1) - 1.0) <= 1e-9
        for i in np.flatnonzero(~unit):
            if not reasons[i]:
                reasons[i] = (
                    f"invalid parameter iquat: {params.iquat[i].tolist()} (not a unit quaternion)"
                )
    # Principal moments of a rigid body obey the triangle inequality (a + b >= c); positive
    # moments that do not (a far tail draw of dispersed moments or products of inertia) are
    # no body, and are not flown (rcsim.spacecraft.dispersions, "Physical tensors").
    with np.errstate(invalid="ignore"):
        m = np.sort(params.inertia_B, axis=1)
        no_body = m[:, 0] + m[:, 1] < m[:, 2] * (1 - 1e-12)
    for i in np.flatnonzero(no_body):
        if not reasons[i]:
            reasons[i] = (
                f"invalid parameter inertia_B: {params.inertia_B[i].tolist()} (principal moments "
                "violate the triangle inequality: no rigid body has them)"
            )
    return reasons
