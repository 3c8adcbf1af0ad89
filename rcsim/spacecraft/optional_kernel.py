"""The optional compiled extensions (built at install when there is a C compiler): one loader.

rcsim has three (``setup.py``): MuJoCo's stage timers on a zero clock
(:mod:`rcsim.spacecraft.mujoco_timers`), the closed loop's per-cycle bookkeeping
(:mod:`rcsim.spacecraft.cycle_kernel`) and the lookup controller's cycle
(:mod:`rcsim.lookup.step_kernel`).  Each is optional: without it the numpy form runs, with the
same results bit for bit.  :class:`OptionalKernel` imports one once and says whether it is in
use -- built, and not switched off by its environment variable (``RCSIM_NUMPY_CYCLE=1``,
``RCSIM_NUMPY_CONTROLLER=1``: the numpy forms, for the tests that compare them).
"""

from __future__ import annotations

import importlib
import os
from dataclasses import dataclass
from types import ModuleType


@dataclass(frozen=True)
class OptionalKernel:
    """One optional extension.

    Attributes
    ----------
    module : module or None
        The compiled module, None when it was not built.
    switch : str or None
        The environment variable that, set to ``1``, keeps the numpy form (None: no switch).
    """

    module: ModuleType | None
    switch: str | None = None

    def available(self) -> bool:
        """Whether the compiled form is built and not switched off (read at each call, so a
        test may switch it per flight)."""
        if self.module is None:
            return False
        return self.switch is None or os.environ.get(self.switch, "") != "1"


def optional_kernel(name: str, switch: str | None = None) -> OptionalKernel:
    """Import the extension ``name`` (e.g. ``"rcsim.spacecraft._cycle_kernel"``) if it was
    built; a missing one is no error (the numpy form runs)."""
    try:
        module = importlib.import_module(name)
    except ImportError:
        module = None
    return OptionalKernel(module, switch)
