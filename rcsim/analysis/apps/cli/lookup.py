"""``rcsim lookup``: generate the lookup table by simulation and compare it with the paper's.

``rcsim lookup generate --out TABLE.csv`` flies the 26 rate cases (paper Table 3) on the nominal
vehicle, writes the table (rcsim layout, loadable by ``--table``) and a companion
``TABLE_settling.csv`` (cycles per axis, residual rate error, settling time, rate-damping
check).  With ``--jets-off 13,15`` it flies the vehicle with those jets failed off and writes the
table for the jets left (its companion records them; the table loads by it).  With ``--vehicle
FILE`` whose jets torque several axes it writes a *channel table* (six axis channels) and its
recipe ``TABLE_recipe.csv`` (:mod:`rcsim.lookup.channels`).  ``rcsim lookup compare`` prints a table
against the paper's Table 6 or 7, case by case.
"""

from __future__ import annotations

import argparse

from rcsim.analysis.apps.cli.lookup_generate import register_generate
from rcsim.analysis.apps.cli.lookup_refine import register_refine
from rcsim.models.errors import InputError


def register(sub) -> None:
    lookup = sub.add_parser(
        "lookup",
        help="generate / compare pattern-recognition lookup tables",
        description="Generate the firing-time lookup table by simulation (Gambone sec. II) "
        "and compare tables with the paper's Tables 6 and 7.",
    )
    cmds = lookup.add_subparsers(dest="lookup_command", metavar="ACTION", parser_class=type(lookup))
    cmds.required = True

    register_generate(cmds)
    db = cmds.add_parser(
        "database",
        help="fire each jet alone under dispersions: the per-jet response database",
        description="Fire every jet of a vehicle alone, for on-times from 10 ms to 0.32 s (those "
        "below the vehicle's minimum on-time are left out: its valves never make them), on "
        "N vehicles dispersed by the vehicle file's Table 5-format table, from rest.  Writes "
        "DB (Parquet: one row per jet, on-time and vehicle: rate change and CG velocity "
        "change), <DB stem>_summary.csv (per jet: change per second of firing and its spread "
        "over the vehicles) and <DB stem>.png.",
    )
    db.add_argument("--vehicle", required=True, metavar="FILE", help="vehicle file or name")
    db.add_argument("--out", required=True, metavar="DB.parquet", help="database to write")
    db.add_argument(
        "--vehicles",
        dest="n_vehicles",
        type=int,
        default=64,
        metavar="N",
        help="dispersed vehicles per jet and on-time (default 64)",
    )
    db.add_argument("--seed", type=int, default=1, metavar="S", help="dispersion seed (default 1)")
    db.add_argument("--overwrite", action="store_true", help="replace existing outputs")
    db.add_argument("--yes", action="store_true", help="start even if estimated over 30 minutes")
    db.set_defaults(func=run_database)

    cmp_ = cmds.add_parser(
        "compare",
        help="compare a lookup table with the paper's Table 6 or 7, case by case",
        description="Print, per case, whether the same jets fire and the firing time per "
        "axis of TABLE and of the paper's table, with the difference in control cycles.",
    )
    cmp_.add_argument(
        "--table",
        metavar="TABLE.csv",
        help="table to compare (default: the packaged generated table)",
    )
    cmp_.add_argument(
        "--which",
        choices=("table6", "table7"),
        default="table6",
        help="paper table (default table6, the original)",
    )
    cmp_.set_defaults(func=run_compare)
    register_refine(cmds)


def run_database(args: argparse.Namespace) -> int:
    from rcsim.analysis.engine.response_files import write_response_database
    from rcsim.spacecraft.dispersions import MAX_SEED

    if not 0 <= args.seed <= MAX_SEED:
        raise InputError(f"--seed must be in 0..2^63 - 1, got {args.seed}")
    from rcsim.analysis.apps.estimates import check_database_cost

    check_database_cost(args.vehicle, args.n_vehicles, yes=args.yes)  # memory, then time
    files = write_response_database(
        args.vehicle, args.out, n_vehicles=args.n_vehicles, seed=args.seed,
        overwrite=args.overwrite,
    )  # fmt: skip
    print(f"wrote {files.database} ({len(files.frame)} flights), {files.summary} and {files.plot}")
    dropped = files.frame.attrs.get("dropped_on_times_s") or []
    if dropped:
        ms = ", ".join(f"{t * 1e3:g}" for t in dropped)
        print(
            f"not flown: on-times {ms} ms, below the vehicle's minimum on-time "
            f"{files.frame.attrs['min_on_s'] * 1e3:g} ms (its valves never make them: their "
            "rows would be zero and pull the slopes toward zero)"
        )
    return 0


def run_compare(args: argparse.Namespace) -> int:
    import pandas as pd

    from rcsim.lookup.jet_sets import load_table_for_jets
    from rcsim.lookup.pattern_recognition import load_default_table
    from rcsim.lookup.table_compare import compare_tables
    from rcsim.models.tables import load_lookup_table

    # A table for failed jets is checked against the jets it was made for (its companion).
    from rcsim.spacecraft.vehicle import Vehicle

    # The paper's tables are in whole cycles of the paper's profile (40 ms); so is the table
    # they are compared with.
    paper_cycle = Vehicle.load().control.cycle_s
    table = (
        load_default_table()
        if args.table is None
        else load_table_for_jets(args.table, cycle_s=paper_cycle)[0]
    )
    if table.recipe is not None:
        raise InputError(
            f"{args.table}: a channel table (six axis channels, for {table.recipe.vehicle}) "
            "has no jets to compare with the paper's tables",
            parameter="table",
            value=args.table,
        )
    from rcsim.spacecraft.vehicle import Vehicle

    # The paper's tables are in whole cycles of the paper's profile (40 ms).
    frame = compare_tables(table, load_lookup_table(which=args.which), paper_cycle)
    with pd.option_context("display.width", 200, "display.max_columns", 20):
        print(frame.to_string(index=False))
    print(
        f"jets agree: {int(frame.jets_agree.sum())}/26; within one cycle: "
        f"{int(frame.within_one_cycle.sum())}/26"
    )
    return 0
