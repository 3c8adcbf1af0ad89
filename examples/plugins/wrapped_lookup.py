"""A plug-in that flies rcsim's own lookup controller: the smallest factory there is.

It shows the factory's signature and is the reference for back-to-back tests and for the
plug-in path's overhead (``benchmarks/plugin_overhead.py``): flown through
``--controller plugin:examples/plugins/wrapped_lookup.py:make_controller`` it must command
exactly what ``--controller lookup`` commands.

Parameters (``[controller.params]`` or ``--param``): ``table``, a lookup table (a path or
``"table6"`` / ``"table7"``; default the packaged table).  The factory declares it
(``table_param``), so ``rcsim lookup refine --controller`` and ``rcsim loop --controller``
refine that table with this plug-in flying it; the controller it returns records the table
rows each run fires (``record_rows`` / ``rows_fired``), so the refinement judges each change
on the cases that fire it, as with the built-in.
"""

from rcsim.lookup.registry import make_controller as builtin


def make_controller(vehicle, params):
    """Factory: ``(vehicle, params) -> Controller``."""
    unknown = set(params) - {"table"}
    if unknown:
        raise ValueError(f"unknown parameter(s) {sorted(unknown)}; this plug-in takes 'table'")
    return builtin("lookup", vehicle, table=params.get("table"))


#: The parameter that takes the table file (rcsim.lookup.table_plugins).
make_controller.table_param = "table"
