"""The compiled pieces of rcsim; everything else is declared in pyproject.toml.

* ``rcsim/spacecraft/_zero_clock.c`` is a zero clock for MuJoCo's stage timers, which rcsim never
  reads (``rcsim/spacecraft/mujoco_timers.py``; its saving per campaign chunk is measured in
  ``docs/performance.md``).
* ``rcsim/lookup/_step_kernel.c`` is the lookup controller's cycle in one pass, bit for bit its
  numpy form (``rcsim/lookup/step_kernel.py``; the controller's share of a chunk before and after
  in ``docs/performance.md``).
* ``rcsim/spacecraft/_cycle_kernel.c`` is the closed loop's per-cycle bookkeeping (navigation's
  quaternion algebra, valve limits and commands, the no-switch test, the propulsion totals),
  bit for bit its numpy forms (``rcsim/spacecraft/cycle_kernel.py``).

All are optional: without a C compiler the build skips them and rcsim runs with MuJoCo's
default timers and the numpy forms.  Declared here rather than in pyproject.toml because
setuptools still calls its ``ext-modules`` table experimental and warns on every install.
"""

import hashlib
from pathlib import Path

from setuptools import Extension, setup


def _digest(source: str) -> list[tuple[str, str]]:
    """The source's SHA-256 as the macro the module exports (``source_sha256``): the loader
    (rcsim/spacecraft/optional_kernel.py) refuses a module built from another source."""
    digest = hashlib.sha256(Path(source).read_bytes()).hexdigest()
    return [("RCSIM_SOURCE_SHA256", f'"{digest}"')]


setup(
    ext_modules=[
        Extension(
            "rcsim.spacecraft._zero_clock",
            ["rcsim/spacecraft/_zero_clock.c"],
            optional=True,
            define_macros=_digest("rcsim/spacecraft/_zero_clock.c"),
        ),
        # Bit for bit the numpy form (rcsim/lookup/step_kernel.py): never fuse a multiply and
        # an add.
        Extension(
            "rcsim.lookup._step_kernel",
            ["rcsim/lookup/_step_kernel.c"],
            optional=True,
            define_macros=_digest("rcsim/lookup/_step_kernel.c"),
            extra_compile_args=["-ffp-contract=off"],
        ),
        # Bit for bit the numpy forms (rcsim/spacecraft/cycle_kernel.py): the same rule.
        Extension(
            "rcsim.spacecraft._cycle_kernel",
            ["rcsim/spacecraft/_cycle_kernel.c"],
            optional=True,
            define_macros=_digest("rcsim/spacecraft/_cycle_kernel.c"),
            extra_compile_args=["-ffp-contract=off"],
        ),
    ]
)
