"""Flight software of a user's own, flown by rcsim: controller plug-ins in Python.

A plug-in is a *factory*, ``factory(vehicle, params) -> Controller``: it receives the
:class:`~rcsim.spacecraft.vehicle.Vehicle` flown (with its flight-software profile,
``vehicle.control``) and a dict of parameters (a campaign spec's ``[controller.params]``, or
``--param KEY=VALUE`` on the command line), and returns an object with the
:class:`~rcsim.spacecraft.controller.Controller` protocol (``cycle_s``, ``initial_state(n)``,
``step(nav, state) -> (on_times, state)``, batched over runs).

A factory is named in one of two ways:

* ``plugin:package.module:factory`` -- any importable module (a spec's
  ``[controller] plugin = "package.module:factory"``), or ``plugin:path/to/fsw.py:factory``,
  a Python file (relative to the working directory; in a spec, to the spec's directory);
* a name an installed distribution registers under the entry-point group
  :data:`ENTRY_POINT_GROUP` (``rcsim.controllers``), e.g. in its ``pyproject.toml``::

      [project.entry-points."rcsim.controllers"]
      theirs = "their_fsw.rcs:make_controller"

  after which ``--controller theirs`` and ``[controller] name = "theirs"`` work like a
  built-in's name (a built-in name always wins: a registration cannot shadow rcsim's own).

What the plug-in was is recorded (:class:`PluginInfo`: the target, the entry point, the
distribution and its version, the SHA-256 of the factory's module source) so a campaign's
manifest says exactly which flight software flew.  Every cycle's on-times are checked
(:class:`CheckedController`): the shape the vehicle's jets need, finite, not negative, not
longer than the cycle; a plug-in that breaks the contract stops with one line naming the
plug-in, the cycle and the run, never with a traceback out of the physics.
"""

from __future__ import annotations

import hashlib
import importlib
import inspect
from dataclasses import asdict, dataclass
from importlib import metadata
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from rcsim.models.errors import InputError

if TYPE_CHECKING:
    from rcsim.spacecraft.controller import Controller
    from rcsim.spacecraft.navigation import NavState
    from rcsim.spacecraft.vehicle import Vehicle

#: How a controller name says "the factory at this import path".
PLUGIN_PREFIX = "plugin:"
#: The entry-point group an installed package registers its controller factories under.
ENTRY_POINT_GROUP = "rcsim.controllers"
#: Slack on "no longer than the cycle": on-times computed as ``cycle_s * fraction`` may round
#: one ulp above the cycle; anything larger is a contract breach.
_CYCLE_SLACK = 1e-12


class PluginError(InputError):
    """A plug-in that cannot be loaded, built or flown (a user's mistake: one line, exit 2)."""


@dataclass(frozen=True)
class PluginInfo:
    """Which flight software flew: what a manifest records.

    Attributes
    ----------
    name : str
        The controller name as given (``plugin:pkg.mod:factory`` or a registered name).
    target : str
        ``package.module:factory`` that was called.
    entry_point : str or None
        The registered name, when the plug-in came from :data:`ENTRY_POINT_GROUP`.
    distribution, version : str or None
        The installed distribution that provides the module, and its version (None for a
        module imported from a plain directory on ``sys.path``).
    source_sha256 : str or None
        SHA-256 of the factory's module file (None when it has no source file).
    """

    name: str
    target: str
    entry_point: str | None
    distribution: str | None
    version: str | None
    source_sha256: str | None

    def record(self) -> dict[str, Any]:
        """JSON-able form (a manifest's ``controller.plugin``)."""
        return asdict(self)


def registered() -> dict[str, str]:
    """Controller names installed packages register: name -> ``package.module:factory``."""
    return {ep.name: ep.value for ep in metadata.entry_points(group=ENTRY_POINT_GROUP)}


def _target(name: str) -> tuple[str, str | None]:
    """``(package.module:factory, entry point or None)`` for a plug-in name."""
    if name.startswith(PLUGIN_PREFIX):
        return name[len(PLUGIN_PREFIX) :], None
    found = registered().get(name)
    if found is None:
        raise PluginError(
            f"controller {name!r}: not a built-in controller and no installed package registers "
            f"it under the entry-point group {ENTRY_POINT_GROUP!r}"
        )
    return found, name


def load_factory(name: str):
    """Import a plug-in's factory.

    Returns
    -------
    factory : callable
    info : PluginInfo

    Raises
    ------
    PluginError
        A malformed target, a module that is not found or fails to import (the module's own
        exception named), a missing attribute, or one that is not callable.
    """
    from rcsim.lookup.c_library import LIBRARY_PREFIX

    if name.startswith(LIBRARY_PREFIX):
        return _library_factory(name, name[len(LIBRARY_PREFIX) :])
    target, entry_point = _target(name)
    module_name, sep, attr = target.partition(":")
    if not sep or not module_name or not attr:
        raise PluginError(
            f"controller {name!r}: a plug-in is named 'package.module:factory' (got {target!r})"
        )
    try:
        module = (
            _import_file(Path(module_name))
            if module_name.endswith(".py")
            else importlib.import_module(module_name)
        )
    except FileNotFoundError:
        raise PluginError(f"controller {name!r}: plug-in file {module_name!r} not found") from None
    except ModuleNotFoundError as exc:
        raise PluginError(
            f"controller {name!r}: plug-in module {module_name!r} not found ({exc}); install "
            "its package or put its directory on PYTHONPATH"
        ) from None
    except Exception as exc:  # noqa: BLE001 - the user's module: any failure is theirs to fix
        raise PluginError(
            f"controller {name!r}: plug-in module {module_name!r} failed to import: "
            f"{type(exc).__name__}: {_one_line(exc)}"
        ) from None
    factory: Any = module
    for part in attr.split("."):
        factory = getattr(factory, part, None)
        if factory is None:
            raise PluginError(
                f"controller {name!r}: module {module_name!r} has no attribute {attr!r}"
            )
    if not callable(factory):
        raise PluginError(f"controller {name!r}: {target!r} is not callable")
    return factory, PluginInfo(
        name=name,
        target=target,
        entry_point=entry_point,
        distribution=(dist := _distribution(module_name)),
        version=None if dist is None else metadata.version(dist),
        source_sha256=_source_sha256(module),
    )


def _library_factory(name: str, path: str):
    """A C library's factory (:class:`rcsim.lookup.c_library.CLibraryController`) and its
    record: the library's path and the SHA-256 of the file."""
    from rcsim.lookup.c_library import CLibraryController, load_library

    load_library(path, name)  # missing, not a library, wrong ABI: refused before the factory

    def factory(vehicle, params):
        return CLibraryController(path, vehicle, params, name)

    digest = hashlib.sha256(Path(path).expanduser().read_bytes()).hexdigest()
    return factory, PluginInfo(name, path, None, None, None, digest)


def build(name: str, vehicle: Vehicle, params: dict | None = None) -> CheckedController:
    """Build plug-in ``name`` for ``vehicle`` and check its contract on one probe cycle.

    The probe (a batch of one run at rest on the commanded attitude, then one at a rate
    error) catches a factory or controller that breaks the protocol before any run flies,
    so a campaign refuses it with one line instead of recording every run failed.

    Raises
    ------
    PluginError
        The factory raised, returned something without the protocol, was built for another
        control cycle, or its probe cycle's on-times break the contract.
    """
    factory, info = load_factory(name)
    try:
        ctl = factory(vehicle, dict(params or {}))
    except InputError:
        raise  # already one line naming the plug-in (a C library's refusals)
    except Exception as exc:  # noqa: BLE001 - the user's factory: its failure is the message
        raise PluginError(
            f"controller {name!r}: its factory raised {type(exc).__name__}: {_one_line(exc)}"
        ) from None
    missing = [a for a in ("cycle_s", "initial_state", "step") if not hasattr(ctl, a)]
    if missing:
        raise PluginError(
            f"controller {name!r}: its factory returned {type(ctl).__name__}, which lacks "
            f"{', '.join(missing)} (the Controller protocol, rcsim/spacecraft/controller.py)"
        )
    cycle_s = vehicle.control.cycle_s
    if not np.isclose(float(ctl.cycle_s), cycle_s, rtol=0, atol=1e-12):
        raise PluginError(
            f"controller {name!r}: built for a {float(ctl.cycle_s):g} s cycle, but the "
            f"vehicle's profile flies {cycle_s:g} s (vehicle.control.cycle_s)"
        )
    checked = CheckedController(ctl, info, vehicle.n_jets)
    checked.probe()
    return checked


class CheckedController:
    """A plug-in's controller with every cycle's on-times checked against the contract.

    Parameters
    ----------
    inner : Controller
        The plug-in's controller.
    info : PluginInfo
    n_jets : int
        The flown vehicle's jet count: the width on-times must have.
    """

    def __init__(self, inner: Controller, info: PluginInfo, n_jets: int) -> None:
        self.inner = inner
        self.info = info
        self.n_jets = int(n_jets)
        self._cycle = 0

    @property
    def cycle_s(self) -> float:
        return float(self.inner.cycle_s)

    def initial_state(self, n_runs: int) -> Any:
        self._cycle = 0
        return self.inner.initial_state(n_runs)

    def step(self, nav: NavState, state: Any) -> tuple[np.ndarray, Any]:
        try:
            on, state = self.inner.step(nav, state)
        except InputError:
            raise  # already one line naming the plug-in, its cycle and run
        except Exception as exc:  # noqa: BLE001 - named with the cycle, as the user's fault
            raise PluginError(
                f"controller {self.info.name!r} raised at cycle {self._cycle} (t = "
                f"{nav.t_s:g} s): {type(exc).__name__}: {_one_line(exc)}"
            ) from None
        on = self.check(on, nav)
        self._cycle += 1
        return on, state

    def check(self, on: Any, nav: NavState) -> np.ndarray:
        """``on`` as a float array (n_runs, n_jets) [s], or :class:`PluginError` naming the
        first run and jet that breaks the contract."""
        where = f"controller {self.info.name!r} at cycle {self._cycle} (t = {nav.t_s:g} s)"
        try:
            arr = np.asarray(on, dtype=float)
        except (TypeError, ValueError):
            raise PluginError(
                f"{where}: returned on-times that are not numbers ({type(on).__name__})"
            ) from None
        want = (nav.n_runs, self.n_jets)
        if arr.shape != want:
            raise PluginError(
                f"{where}: returned on-times of shape {arr.shape}, expected {want} "
                "(runs, jets of the vehicle flown)"
            )
        limit = self.cycle_s * (1 + _CYCLE_SLACK)
        bad = ~np.isfinite(arr) | (arr < 0) | (arr > limit)
        if bad.any():
            run, jet = (int(i) for i in np.argwhere(bad)[0])
            value = float(arr[run, jet])
            why = (
                "is not finite"
                if not np.isfinite(value)
                else "is negative"
                if value < 0
                else f"is longer than the {self.cycle_s:g} s cycle"
            )
            raise PluginError(
                f"{where}: run {run} jet {jet + 1} on-time {value!r} s {why}; "
                f"{int(bad.sum())} value(s) break the contract this cycle"
            )
        return arr

    def probe(self) -> None:
        """One cycle for one run at rest and one with a rate error: the contract checked
        before any flight (the state is thrown away)."""
        from rcsim.spacecraft.navigation import NavState

        zero = np.zeros((2, 3))
        rate = np.array([[0.0, 0.0, 0.0], [1e-3, -1e-3, 1e-3]])  # [rad/s]: any small error
        q = np.tile([1.0, 0.0, 0.0, 0.0], (2, 1))
        nav = NavState(
            t_s=0.0, q_BN=q, omega_B=rate, att_err_B=zero, rate_err_B=rate, omega_cmd_B=zero
        )
        self.step(nav, self.initial_state(2))
        self._cycle = 0


def _import_file(path: Path):
    """Import a plug-in given as a ``.py`` file (``plugin:path/to/fsw.py:factory``), under a
    module name made from its resolved path, so the same file is imported once per process."""
    import importlib.util
    import sys

    path = path.expanduser().resolve()
    if not path.is_file():
        raise FileNotFoundError(path)
    key = "rcsim_plugin_" + hashlib.sha256(str(path).encode()).hexdigest()[:16]
    if key in sys.modules:
        return sys.modules[key]
    spec = importlib.util.spec_from_file_location(key, path)
    assert spec is not None and spec.loader is not None  # a .py file always has a loader
    module = importlib.util.module_from_spec(spec)
    sys.modules[key] = module
    try:
        spec.loader.exec_module(module)
    except BaseException:
        del sys.modules[key]  # a failed import must not be found half-made next time
        raise
    return module


def _distribution(module_name: str) -> str | None:
    """The installed distribution providing top-level package of ``module_name``, if any."""
    if module_name.endswith(".py"):
        return None  # a file, not an installed package
    top = module_name.split(".")[0]
    dists = metadata.packages_distributions().get(top) or []
    return dists[0] if dists else None


def _source_sha256(module) -> str | None:
    """SHA-256 of a module's source file (None for one without a file, e.g. a builtin)."""
    try:
        path = inspect.getsourcefile(module)
    except TypeError:
        return None
    if path is None or not Path(path).is_file():
        return None
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def _one_line(exc: BaseException) -> str:
    """An exception's message on one line (a user's exception may span several)."""
    return " ".join(str(exc).split()) or type(exc).__name__
