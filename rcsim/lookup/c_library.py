"""Flight software in C, flown through rcsim's C ABI (``rcsim/lookup/c_abi/rcsim_fsw.h``).

The library is loaded with :mod:`ctypes` (the standard library: nothing to install, no
compiler at run time; cffi would add a dependency for no gain at one call per cycle).  One
call per control cycle for the whole batch: the arrays of every run go in, the library loops
over the runs, so the per-call cost (a few microseconds) stays out of the per-run work.

rcsim owns the state: one buffer of ``rcsim_fsw_state_bytes`` bytes per run, in one numpy
array ``(n_runs, state_bytes)``, so runs are independent and any run replays alone.

A library is named ``library:path/to/libfsw.so`` (the controller name) or, in a campaign
spec, ``[controller] library = "path/to/libfsw.so"``; it is built like a Python plug-in
(:func:`rcsim.lookup.plugins.build`: probed once before any run, its on-times checked every
cycle).  A crash inside the library can only be survived in another process: campaigns fly a
library's chunks in worker processes, and ``RCSIM_FSW_BEACON`` (set by the process that
re-flies a crashed chunk) names a file the controller writes its cycle to before each call,
so the crash is reported with its run and cycle.
"""

from __future__ import annotations

import ctypes
import math
import os
from importlib.resources import files
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from rcsim.models.errors import InputError

if TYPE_CHECKING:
    from rcsim.spacecraft.navigation import NavState
    from rcsim.spacecraft.vehicle import Vehicle

#: The ABI version rcsim speaks (``RCSIM_FSW_ABI_VERSION`` in the header).
ABI_VERSION = 1
#: How a controller name says "the C library at this path".
LIBRARY_PREFIX = "library:"
#: Environment variable naming the file a controller writes ``cycle t_s`` to before each call.
BEACON_ENV = "RCSIM_FSW_BEACON"
_SYMBOLS = ("rcsim_fsw_abi_version", "rcsim_fsw_state_bytes", "rcsim_fsw_init", "rcsim_fsw_step")


def header_path() -> Path:
    """The ABI's header, shipped in the package: ``cc -I "$(dirname PATH)"``."""
    return Path(str(files("rcsim.lookup.c_abi") / "rcsim_fsw.h"))


class _Config(ctypes.Structure):
    _fields_ = [
        ("abi_version", ctypes.c_int32),
        ("n_jets", ctypes.c_int32),
        ("cycle_s", ctypes.c_double),
        ("n_values", ctypes.c_int32),
        ("names", ctypes.POINTER(ctypes.c_char_p)),
        ("values", ctypes.POINTER(ctypes.c_double)),
        ("jet_torque_n_m", ctypes.POINTER(ctypes.c_double)),
        ("n_texts", ctypes.c_int32),
        ("text_names", ctypes.POINTER(ctypes.c_char_p)),
        ("text_values", ctypes.POINTER(ctypes.c_char_p)),
    ]


def _ptr(a: np.ndarray, kind=ctypes.c_double):
    return a.ctypes.data_as(ctypes.POINTER(kind))


def load_library(path: str | os.PathLike, name: str):
    """Open the library and check its ABI version and symbols.

    Raises
    ------
    InputError
        The file is missing or not a loadable library, a symbol is missing, or it was built
        for another ABI version.
    """
    path = Path(path).expanduser()
    if not path.is_file():
        raise InputError(f"controller {name!r}: library {str(path)!r} not found")
    try:
        lib = ctypes.CDLL(str(path.resolve()))
    except OSError as exc:
        raise InputError(
            f"controller {name!r}: {str(path)!r} is not a loadable shared library ({exc})"
        ) from None
    missing = [s for s in _SYMBOLS if not hasattr(lib, s)]
    if missing:
        raise InputError(
            f"controller {name!r}: library {str(path)!r} lacks {', '.join(missing)} (the C ABI: "
            f"{header_path().name})"
        )
    lib.rcsim_fsw_abi_version.restype = ctypes.c_int32
    lib.rcsim_fsw_abi_version.argtypes = []
    version = int(lib.rcsim_fsw_abi_version())
    if version != ABI_VERSION:
        raise InputError(
            f"controller {name!r}: library {str(path)!r} was built for C ABI version {version}; "
            f"this rcsim speaks version {ABI_VERSION} (rebuild it against {header_path().name})"
        )
    cfg = ctypes.POINTER(_Config)
    dbl = ctypes.POINTER(ctypes.c_double)
    lib.rcsim_fsw_state_bytes.restype = ctypes.c_int64
    lib.rcsim_fsw_state_bytes.argtypes = [cfg]
    lib.rcsim_fsw_init.restype = ctypes.c_int32
    lib.rcsim_fsw_init.argtypes = [cfg, ctypes.c_int64, ctypes.c_void_p]
    lib.rcsim_fsw_step.restype = ctypes.c_int32
    lib.rcsim_fsw_step.argtypes = [
        cfg, ctypes.c_int64, ctypes.c_double, dbl, dbl, dbl, ctypes.c_void_p, dbl,
        ctypes.POINTER(ctypes.c_int32),
    ]  # fmt: skip
    return lib


def profile_values(vehicle: Vehicle) -> dict[str, float]:
    """The profile's numbers, SI, by field name (units in the names): what the config passes."""
    import dataclasses

    control = vehicle.control
    return {
        f.name: float(getattr(control, f.name))
        for f in dataclasses.fields(control)
        if isinstance(getattr(control, f.name), float)
    }


class CLibraryController:
    """A controller whose cycle is the library's ``rcsim_fsw_step`` (batched, explicit state).

    Parameters
    ----------
    path : path
        The shared library.
    vehicle : Vehicle
        The vehicle flown: its jet count, cycle, profile and jet torques go to the library.
    params : dict
        Numbers passed after the profile's (``[controller.params]``).
    name : str
        The controller name, for messages.
    """

    def __init__(self, path, vehicle: Vehicle, params: dict, name: str) -> None:
        self.path = Path(path)
        self.name = name
        self.lib = load_library(path, name)
        values = profile_values(vehicle)
        texts: dict[str, str] = {}
        for key, value in params.items():
            if isinstance(value, str):
                texts[key] = value
                continue
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise InputError(
                    f"controller {name!r}: parameter {key!r} must be a number or a string for "
                    f"a C library (got {value!r})"
                )
            if key in values:
                raise InputError(
                    f"controller {name!r}: parameter {key!r} is a profile value; set it in the "
                    "vehicle's [control] instead"
                )
            values[key] = float(value)
        self.n_jets = vehicle.n_jets
        self._cycle_s = vehicle.control.cycle_s
        # Kept alive on self: the config points into these for every call.
        self._names = (ctypes.c_char_p * len(values))(*(k.encode() for k in values))
        self._values = np.ascontiguousarray(list(values.values()), dtype=float)
        # The vehicle file's torques, from which its axis_signs (Table 2 rule) are read.
        self._torque = np.ascontiguousarray(vehicle.force_torque()[3:].T, dtype=float)
        self._text_names = (ctypes.c_char_p * max(len(texts), 1))(*(k.encode() for k in texts))
        self._text_values = (ctypes.c_char_p * max(len(texts), 1))(
            *(v.encode() for v in texts.values())
        )
        self.config = _Config(
            ABI_VERSION, self.n_jets, self._cycle_s, len(values), self._names,
            _ptr(self._values), _ptr(self._torque), len(texts), self._text_names,
            self._text_values,
        )  # fmt: skip
        size = int(self.lib.rcsim_fsw_state_bytes(ctypes.byref(self.config)))
        if size < 0:
            raise InputError(
                f"controller {name!r}: the library refused its configuration "
                f"(rcsim_fsw_state_bytes returned {size})"
            )
        self.state_bytes = size
        beacon = os.environ.get(BEACON_ENV)
        self._beacon = None if not beacon else os.open(beacon, os.O_WRONLY | os.O_CREAT, 0o644)
        self._cycle = 0

    @property
    def cycle_s(self) -> float:
        return self._cycle_s

    def initial_state(self, n_runs: int) -> np.ndarray:
        """The runs' state buffers, ``(n_runs, max(state_bytes, 1))`` bytes, initialised by
        the library."""
        states = np.zeros((n_runs, max(self.state_bytes, 1)), dtype=np.uint8)
        code = int(self.lib.rcsim_fsw_init(ctypes.byref(self.config), n_runs, states.ctypes.data))
        if code != 0:
            raise InputError(f"controller {self.name!r}: rcsim_fsw_init returned {code}")
        self._cycle = 0
        self._last_states = states  # what rows_fired reads after the flight
        return states

    def step(self, nav: NavState, state: Any) -> tuple[np.ndarray, Any]:
        n = nav.n_runs
        att = np.ascontiguousarray(nav.att_err_B, dtype=float)
        rate = np.ascontiguousarray(nav.rate_err_B, dtype=float)
        omega = np.ascontiguousarray(nav.omega_B, dtype=float)
        states = np.array(state, dtype=np.uint8, copy=True, order="C")  # state in, new out
        on = np.zeros((n, self.n_jets))
        status = np.zeros(n, dtype=np.int32)
        if self._beacon is not None:  # where a crash happened, for the process that watches
            os.pwrite(self._beacon, f"{self._cycle} {nav.t_s!r}\n".ljust(64).encode(), 0)
        code = int(
            self.lib.rcsim_fsw_step(
                ctypes.byref(self.config), n, float(nav.t_s), _ptr(att), _ptr(rate),
                _ptr(omega), states.ctypes.data, _ptr(on), _ptr(status, ctypes.c_int32),
            )
        )  # fmt: skip
        where = f"controller {self.name!r} at cycle {self._cycle} (t = {nav.t_s:g} s)"
        if code != 0:
            raise InputError(f"{where}: rcsim_fsw_step returned {code}")
        if status.any():
            bad = np.flatnonzero(status)
            raise InputError(
                f"{where}: run {int(bad[0])} status {int(status[bad[0]])} "
                f"({bad.size} of {n} runs non-zero)"
            )
        self._cycle += 1
        self._last_states = states
        return on, states

    def record_rows(self) -> CLibraryController:
        """Nothing to switch on: a library that records the table rows its runs fire keeps
        them in the runs' states (:attr:`rows_fired`)."""
        return self

    @property
    def rows_fired(self) -> np.ndarray | None:
        """``(n_runs,)`` int64 bitmask of the table rows each run of the last flight fired
        (the optional ``rcsim_fsw_rows_fired``), or None if the library does not say."""
        func = getattr(self.lib, "rcsim_fsw_rows_fired", None)
        states = getattr(self, "_last_states", None)
        if func is None or states is None:
            return None
        func.restype = ctypes.c_int32
        func.argtypes = [ctypes.POINTER(_Config), ctypes.c_int64, ctypes.c_void_p, ctypes.c_void_p]
        rows = np.zeros(states.shape[0], dtype=np.uint64)
        code = int(
            func(ctypes.byref(self.config), states.shape[0], states.ctypes.data, rows.ctypes.data)
        )
        if code != 0:
            raise InputError(f"controller {self.name!r}: rcsim_fsw_rows_fired returned {code}")
        return rows.astype(np.int64)


def read_beacon(path: str | os.PathLike) -> tuple[int, float] | None:
    """``(cycle, t_s)`` a controller last wrote to the beacon file, or None."""
    try:
        text = Path(path).read_text().split()
    except OSError:
        return None
    if len(text) < 2:
        return None
    t_s = float(text[1])
    return int(text[0]), (t_s if math.isfinite(t_s) else float("nan"))
