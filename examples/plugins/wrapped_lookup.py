"""A plug-in that flies rcsim's own lookup controller: the smallest factory there is.

It shows the factory's signature and is the reference for back-to-back tests and for the
plug-in path's overhead (``benchmarks/plugin_overhead.py``): flown through
``--controller plugin:examples/plugins/wrapped_lookup.py:make_controller`` it must command
exactly what ``--controller lookup`` commands.

Parameters (``[controller.params]`` or ``--param``): ``table``, a lookup table (a path or
``"table6"`` / ``"table7"``; default the packaged table).
"""

from rcsim.lookup.registry import make_controller as builtin


def make_controller(vehicle, params):
    """Factory: ``(vehicle, params) -> Controller``."""
    unknown = set(params) - {"table"}
    if unknown:
        raise ValueError(f"unknown parameter(s) {sorted(unknown)}; this plug-in takes 'table'")
    return builtin("lookup", vehicle, table=params.get("table"))
