"""The lookup controller's cycle as one compiled pass (the optional extension `_step_kernel.c`).

:meth:`rcsim.lookup.pattern_recognition.LookupController.step_detail` is written in numpy: about 45
calls on ``(n_runs, n_jets)`` arrays per cycle, each a few microseconds, which made the
controller the largest part of a campaign's per-cycle Python work (``docs/performance.md``).
The kernel does the same arithmetic in the same order, run by run, in one call; its results
are the numpy form's bit for bit (``tests/lookup/test_step_kernel.py``).  The numpy form stays
the reference and runs whenever the extension was not built (no C compiler at install) or
``RCSIM_NUMPY_CONTROLLER=1`` is set.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rcsim.spacecraft.optional_kernel import optional_kernel

_KERNEL = optional_kernel("rcsim.lookup._step_kernel", "RCSIM_NUMPY_CONTROLLER")
#: The compiled module (None when built without a C compiler: the numpy form runs).
_step_kernel: Any = _KERNEL.module  # its functions are called only when available()


def kernel_available() -> bool:
    """Whether the compiled cycle is built and not switched off by ``RCSIM_NUMPY_CONTROLLER``."""
    return _KERNEL.available()


def _f64(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float64)


def kernel_step(
    att_err_B: np.ndarray,
    theta_rad: np.ndarray,
    rate_err_B: np.ndarray,
    remaining_s: np.ndarray,
    hold_s: np.ndarray,
    maneuver: np.ndarray,
    times_s: np.ndarray,
    case_scale: np.ndarray | None,
    case_of_code: np.ndarray,
    rate_abs: np.ndarray,
    jet_axis: np.ndarray,
    jet_group: np.ndarray,
    opp_group: np.ndarray,
    limits: tuple[float, ...],
) -> tuple[np.ndarray, ...]:
    """One cycle of every run; the arguments are the controller's arrays (see step_detail),
    ``theta_rad`` (n_runs,) the total attitude error as step_detail computes it (numpy's
    einsum has its own summation order; computing it once, there, keeps the two forms equal
    on any numpy), ``maneuver`` (n_runs,) bool whether the run flies the maneuver rate (the
    hysteresis is decided there too).

    Returns
    -------
    on_s, remaining_next_s : ndarray, (n_runs, n_jets)
    hold_next_s, need : ndarray, (n_runs, 3)
    case : ndarray of int64, (n_runs,)
    axis_new, axis_done : ndarray of bool, (n_runs, 3)
    """
    n = att_err_B.shape[0]
    n_jets = remaining_s.shape[1]
    n_cases = times_s.shape[-2]
    on = np.empty((n, n_jets))
    rem_next = np.empty((n, n_jets))
    hold = np.empty((n, 3))
    need = np.empty((n, 3))
    case = np.empty(n, np.int64)
    axis_new = np.empty((n, 3), np.bool_)
    axis_done = np.empty((n, 3), np.bool_)
    scale = np.zeros(1) if case_scale is None else _f64(case_scale)
    _step_kernel.step(
        n,
        n_jets,
        n_cases,
        int(times_s.ndim == 3),
        case_scale is not None,
        _f64(att_err_B),
        _f64(theta_rad),
        _f64(rate_err_B),
        _f64(remaining_s),
        _f64(hold_s),
        np.ascontiguousarray(maneuver, np.bool_).view(np.uint8),
        _f64(times_s),
        scale,
        case_of_code,
        rate_abs,
        jet_axis,
        jet_group,
        opp_group,
        on,
        rem_next,
        hold,
        case,
        need,
        axis_new.view(np.uint8),
        axis_done.view(np.uint8),
        *limits,
    )
    return on, rem_next, hold, need, case, axis_new, axis_done
