"""The loop's files: what it calls its table refined, where it keeps a generated one (shared by
the stages, :mod:`rcsim.analysis.apps.loop.run`, and the report,
:mod:`rcsim.analysis.apps.loop.report`), and the campaign specs it writes for a user to read."""

from __future__ import annotations

import json
from pathlib import Path

from rcsim.analysis.apps.refinement.parameters import rate_cases_campaign
from rcsim.models.tables import PAPER_LOOKUP_TABLES
from rcsim.spacecraft.vehicle import Vehicle

#: The table setting that makes the loop generate its table first (stage ``generate``).
GENERATE = "generate"
#: Where the generated table goes in the loop directory (beside it: its recipe and settling
#: companion).
GENERATED_TABLE = "generated_table.csv"


def table_file(out: Path, table: str) -> str:
    """How the loop's campaigns name the table refined: the paper's by name, a file by its
    absolute path, the generated one by its path in ``out``."""
    if table == GENERATE:
        return str(Path(out) / GENERATED_TABLE)
    return table if table in PAPER_LOOKUP_TABLES else str(Path(table).absolute())


def spec_text(
    *,
    table: str,
    runs_per_case: int,
    seed: int,
    duration_s: float,
    plots: bool = True,
    vehicle: Vehicle | None = None,
    name_vehicle: bool = False,
    controller: str = "lookup",
    controller_params: dict | None = None,
) -> str:
    """The refinement's rate-case campaign (:func:`rate_cases_campaign`) as a TOML spec, with
    failure histories and (unless ``plots`` is false) plots kept: a user reads these.
    ``name_vehicle``: the user named the vehicle (``--vehicle paper`` is written too).
    ``controller``: a plug-in that flies the table (its table file among
    ``controller_params``), else rcsim's lookup controller."""
    data = rate_cases_campaign(
        runs_per_case=runs_per_case,
        seed=seed,
        duration_s=duration_s,
        table=table,
        histories="failures",
        plots=plots,
        vehicle=vehicle,
        name_vehicle=name_vehicle,
        controller=controller,
        controller_params=controller_params,
    )
    named = vehicle is not None and vehicle.ref != "paper"
    disp = "the vehicle file's [dispersions]" if named else "Table 5 dispersions"
    lines = [f"# Written by `rcsim loop`: the 26 Table 3 rate cases, {disp}."]
    scalars = {k: v for k, v in data.items() if not isinstance(v, dict)}
    lines += [f"{k} = {_toml(v)}" for k, v in scalars.items()]
    for name, table_ in data.items():
        if isinstance(table_, dict):
            flat = {k: v for k, v in table_.items() if not isinstance(v, dict)}
            lines += ["", f"[{name}]"] + [f"{_key(k)} = {_toml(v)}" for k, v in flat.items()]
            for sub, inner in table_.items():  # [controller.params]
                if isinstance(inner, dict):
                    lines += ["", f"[{name}.{sub}]"]
                    lines += [f"{_key(k)} = {_toml(v)}" for k, v in inner.items()]
    return "\n".join(lines) + "\n"


def _toml(value) -> str:
    """A TOML scalar: JSON's spelling is TOML's for strings, numbers and booleans."""
    return json.dumps(value)


def _key(name: str) -> str:
    """A TOML key: dotted keys (``phase_plane.rate_deadband_deg_s``) as written."""
    return name
