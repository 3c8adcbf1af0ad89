"""The optional compiled extensions (built at install when there is a C compiler): one loader.

rcsim has three (``setup.py``): MuJoCo's stage timers on a zero clock
(:mod:`rcsim.spacecraft.mujoco_timers`), the closed loop's per-cycle bookkeeping
(:mod:`rcsim.spacecraft.cycle_kernel`) and the lookup controller's cycle
(:mod:`rcsim.lookup.step_kernel`).  Each is optional: without it the numpy form runs, with the
same results bit for bit.  :class:`OptionalKernel` imports one once and says whether it is in
use -- built, and not switched off by its environment variable (``RCSIM_NUMPY_CYCLE=1``,
``RCSIM_NUMPY_CONTROLLER=1``: the numpy forms, for the tests that compare them).

A module built from another source than the one beside it (an editable install not rebuilt
after the C file changed: its functions may take other arguments) is not used: the numpy form
runs, with one warning saying how to rebuild.  The build records the source's SHA-256 in the
module (``source_sha256``, ``setup.py``); an installed wheel ships no C source and is trusted.
"""

from __future__ import annotations

import hashlib
import importlib
import os
import warnings
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
    if module is not None and is_stale(module):
        warnings.warn(
            f"{name} was built from an older source than its .c file: the numpy form runs "
            "(rebuild with `pip install -e .` or `make` after deleting .venv/.installed)",
            RuntimeWarning,
            stacklevel=2,
        )
        module = None
    return OptionalKernel(module, switch)


def is_stale(module: ModuleType) -> bool:
    """Whether a compiled module's recorded source digest differs from the digest of the C
    source beside it (False when either is missing: nothing to compare)."""
    built = getattr(module, "source_sha256", None)
    origin = getattr(module, "__file__", None)
    if built is None or origin is None:
        return False
    stem = module.__name__.rsplit(".", 1)[-1]
    source = os.path.join(os.path.dirname(origin), stem + ".c")
    if not os.path.isfile(source):
        return False
    with open(source, "rb") as fh:
        return hashlib.sha256(fh.read()).hexdigest() != built
