"""MuJoCo's per-stage timers, switched off for the simulations rcsim flies.

With no timer callback installed, MuJoCo 4 times every stage of every step with the system
clock and accumulates the durations in ``MjData.timer``: about 90 clock reads per RK4 step of
this vehicle, a fifth of its cost (``docs/performance.md``).  rcsim never reads those timers,
so it installs a callback that reads zero: a native function (``rcsim/spacecraft/_zero_clock.c``),
because MuJoCo calls it from its own threads, outside the interpreter.  The physics is
untouched: the timers feed nothing but ``MjData.timer``.

The callback is process-wide.  It is installed only where none is set, so a user's own
callback is never replaced, and not at all when the optional extension was not built (no C
compiler at install): rcsim then runs as before, with MuJoCo's own timers.
"""

from __future__ import annotations

import ctypes

import mujoco

from rcsim.spacecraft.optional_kernel import optional_kernel

_ZeroClock = ctypes.CFUNCTYPE(ctypes.c_double)
#: The installed callback object, kept alive for as long as MuJoCo may call it.
_callback: object | None = None


_KERNEL = optional_kernel("rcsim.spacecraft._zero_clock")


def zero_clock_available() -> bool:
    """Whether the optional native zero clock was built with this install."""
    return _KERNEL.available()


def quiet_stage_timers() -> bool:
    """Install the zero clock as MuJoCo's timer callback unless one is already set.

    Returns
    -------
    bool
        True when MuJoCo's stage timers read the zero clock after the call (installed now or
        before), False when the extension is missing or another callback is in place.
    """
    global _callback
    current = mujoco.get_mjcb_time()
    if _callback is not None and current is not None:
        return True
    if current is not None or _KERNEL.module is None:
        return False
    _callback = _ZeroClock(_KERNEL.module.address())
    mujoco.set_mjcb_time(_callback)
    return True
