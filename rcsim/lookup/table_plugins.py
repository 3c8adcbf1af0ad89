"""A plug-in that flies a lookup table, refined with the plug-in flying it.

A plug-in (:mod:`rcsim.lookup.plugins`) whose logic flies a lookup table may *declare* the
parameter that takes the table file:

* a Python factory by an attribute, ``make_controller.table_param = "table"``;
* a C library (:mod:`rcsim.lookup.c_library`) by the optional symbol
  ``const char *rcsim_fsw_table_param(void)`` returning the name of its text parameter.

``rcsim lookup refine --controller NAME`` and ``rcsim loop --controller NAME`` then refine the
table with that plug-in flying every candidate: each candidate table is written (rcsim
layout, :meth:`rcsim.models.tables.LookupTable.to_csv`) to a file of its own, passed under
the declared parameter, and the plug-in is built for it (:func:`rcsim.lookup.plugins.build`,
probed and checked every cycle as anywhere else).  The runs of one candidate fly as one batch:
a plug-in sees one table per controller, as it would in a campaign.

Which table rows a run fired
----------------------------
The refinement judges a changed row on every case whose runs fire it.  A plug-in's controller
may say which rows it fired: a method ``record_rows()`` (called before the flight) and an
attribute ``rows_fired``, ``(n_runs, n_rows)`` bool, after it -- the built-in
:class:`~rcsim.lookup.pattern_recognition.LookupController` has both, so a plug-in that wraps
it refines bit for bit as the built-in.  A plug-in without them is taken to fire every row in
every run: each candidate is then judged on every searched case (more runs flown, the same
decisions on runs that do not fire the row, since their flights do not change).
"""

from __future__ import annotations

import ctypes
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from rcsim.lookup.plugins import PluginError, build, load_factory
from rcsim.models.errors import InputError

if TYPE_CHECKING:
    from rcsim.models.tables import LookupTable
    from rcsim.spacecraft.vehicle import Vehicle

#: The attribute by which a Python factory names the parameter that takes its table file.
TABLE_PARAM_ATTRIBUTE = "table_param"
#: The optional C symbol by which a library names it (a ``const char *`` function).
TABLE_PARAM_SYMBOL = "rcsim_fsw_table_param"


def declared_table_param(name: str) -> str | None:
    """The parameter through which plug-in ``name`` takes a lookup table file, or None if it
    declares none (see the module docstring).

    Raises
    ------
    PluginError
        The plug-in does not load, or declares something that is not a parameter name.
    """
    from rcsim.lookup.c_library import LIBRARY_PREFIX, load_library

    if name.startswith(LIBRARY_PREFIX):
        lib = load_library(name[len(LIBRARY_PREFIX) :], name)
        if not hasattr(lib, TABLE_PARAM_SYMBOL):
            return None
        func = getattr(lib, TABLE_PARAM_SYMBOL)
        func.restype = ctypes.c_char_p
        func.argtypes = []
        raw = func()
        key: Any = None if raw is None else raw.decode("utf-8", "replace")
    else:
        factory, _ = load_factory(name)
        key = getattr(factory, TABLE_PARAM_ATTRIBUTE, None)
        if key is None:
            return None
    if not isinstance(key, str) or not key.strip():
        raise PluginError(
            f"controller {name!r}: declares its table parameter as {key!r}; it must be the "
            "name of the parameter that takes the table file"
        )
    return key


@dataclass(frozen=True)
class TablePlugin:
    """A plug-in flying the candidate tables of a refinement (picklable: sent to workers).

    Attributes
    ----------
    name : str
        The controller name (``plugin:...``, ``library:...`` or a registered name); a plug-in
        file's path is absolute, so every worker process finds it.
    params : dict
        Its other parameters (``[controller.params]`` / ``--param``), without the table's.
    key : str
        The parameter it takes its table file through (:func:`declared_table_param`).
    record : dict
        What the plug-in was (:meth:`rcsim.lookup.plugins.PluginInfo.record`): the
        refinement's outputs say which flight software flew.
    """

    name: str
    params: dict = field(default_factory=dict)
    key: str = "table"
    record: dict = field(default_factory=dict)

    @classmethod
    def for_refinement(
        cls, name: str, params: dict | None, vehicle: Vehicle, table: LookupTable
    ) -> TablePlugin:
        """Check that ``name`` can fly the refinement of ``table`` on ``vehicle`` and return it.

        The plug-in must declare a table parameter, and must not be given that parameter
        (the refinement passes each candidate itself); it is built once on ``table`` and
        probed, so that a plug-in that cannot fly it is refused before any run.

        Raises
        ------
        InputError
            One line naming the plug-in and what is wrong.
        """
        params = dict(params or {})
        key = declared_table_param(name)
        if key is None:
            raise InputError(
                f"controller {name!r} declares no lookup-table parameter, so there is no table "
                f"of its to refine (a Python factory declares one with `factory."
                f"{TABLE_PARAM_ATTRIBUTE} = 'table'`, a C library with "
                f"{TABLE_PARAM_SYMBOL}(); docs/flight_software.md)"
            )
        if key in params:
            raise InputError(
                f"controller {name!r}: its parameter {key!r} is the table the refinement "
                f"passes each candidate through; give the table to refine as --table, not "
                f"--param {key}=...",
                parameter="params",
                value=params[key],
            )
        plugin = cls(name, params, key, {})
        with plugin.tables(table, np.asarray(table.firing_time_s, float)[None]) as paths:
            checked = build(name, vehicle, plugin.params_for(paths[0]))
        return cls(name, params, key, checked.info.record())

    def params_for(self, path: Path) -> dict:
        """The plug-in's parameters with the table file ``path`` under its key."""
        return {**self.params, self.key: str(path)}

    @contextmanager
    def tables(self, table: LookupTable, times_s: np.ndarray) -> Iterator[list[Path]]:
        """Each of ``times_s`` ``(n, rows, jets)`` [s] as ``table`` with those firing times,
        written to a temporary file (removed on exit)."""
        from rcsim.lookup.table_edits import with_times

        with tempfile.TemporaryDirectory(prefix="rcsim-candidates-") as tmp:
            paths = []
            for i, times in enumerate(np.asarray(times_s, float)):
                path = Path(tmp) / f"candidate_{i}.csv"
                with_times(table, times, source=str(path)).to_csv(path)
                paths.append(path)
            yield paths

    def controllers(
        self, vehicle: Vehicle, table: LookupTable, run_times_s: np.ndarray
    ) -> Iterator[tuple[np.ndarray, Any]]:
        """The plug-in built for each distinct table among the runs' ``run_times_s``
        ``(n_runs, rows, jets)`` [s]: ``(run indices, controller)``, one group at a time
        (flown before the next is built: a library may keep its table per process)."""
        times = np.asarray(run_times_s, float)
        flat = times.reshape(times.shape[0], -1)
        distinct, group = np.unique(flat, axis=0, return_inverse=True)
        group = np.asarray(group).reshape(-1)
        with self.tables(table, distinct.reshape((-1, *times.shape[1:]))) as paths:
            for g, path in enumerate(paths):
                ctl = build(self.name, vehicle, self.params_for(path))
                inner: Any = ctl.inner
                if callable(getattr(inner, "record_rows", None)):
                    inner.record_rows()
                yield np.flatnonzero(group == g), ctl

    def rows_fired(self, controller: Any, n_runs: int, n_rows: int) -> np.ndarray:
        """``(n_runs, n_rows)`` bool: the rows the flight fired, as the plug-in recorded them
        (``rows_fired``: ``(n_runs, n_rows)`` bool, or an ``(n_runs,)`` integer bitmask, bit
        ``r`` for row ``r``, as a C library gives it), or every row when it records none (see
        the module docstring)."""
        rows = getattr(getattr(controller, "inner", controller), "rows_fired", None)
        if rows is None:
            return np.ones((n_runs, n_rows), bool)
        rows = np.asarray(rows)
        if rows.ndim == 1 and np.issubdtype(rows.dtype, np.integer):
            if n_rows > 63:
                raise PluginError(
                    f"controller {self.name!r}: a bitmask of rows_fired holds at most 63 table "
                    f"rows, the table has {n_rows}"
                )
            bits = np.left_shift(np.int64(1), np.arange(n_rows, dtype=np.int64))
            rows = (rows.astype(np.int64)[:, None] & bits[None, :]) != 0
        rows = rows.astype(bool)
        if rows.shape != (n_runs, n_rows):
            raise PluginError(
                f"controller {self.name!r}: rows_fired has shape {rows.shape}, expected "
                f"{(n_runs, n_rows)} (runs, table rows)"
            )
        return rows

    def describe(self) -> str:
        """One line for outputs: the plug-in, its version or source digest."""
        rec = self.record
        what = rec.get("version") or (rec.get("source_sha256") or "")[:12]
        return f"{self.name}" + (f" ({what})" if what else "")
