"""The one compiled piece of rcsim; everything else is declared in pyproject.toml.

``spacecraft/_zero_clock.c`` is a zero clock for MuJoCo's stage timers, which rcsim never
reads (``spacecraft/mujoco_timers.py``; -19 % per campaign chunk, ``docs/performance.md``).
It is optional: without a C compiler the build skips it and rcsim runs with MuJoCo's default
timers.  Declared here rather than in pyproject.toml because setuptools still calls its
``ext-modules`` table experimental and warns on every install.
"""

from setuptools import Extension, setup

setup(
    ext_modules=[Extension("spacecraft._zero_clock", ["spacecraft/_zero_clock.c"], optional=True)]
)
