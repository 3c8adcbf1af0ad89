"""``rcsim lookup``: generate the lookup table by simulation and compare it with the paper's.

``rcsim lookup generate --out TABLE.csv`` flies the 26 rate cases (paper Table 3) on the nominal
vehicle, writes the table (rcsim layout, loadable by ``--table``) and a companion
``TABLE_settling.csv`` (cycles per axis, residual rate error, settling time, rate-damping
check).  ``rcsim lookup compare`` prints a table against the paper's Table 6 or 7, case by case.
"""
from __future__ import annotations

import argparse
from pathlib import Path

from rcsim.models.errors import InputError


def register(sub) -> None:
    lookup = sub.add_parser(
        "lookup",
        help="generate / compare pattern-recognition lookup tables",
        description="Generate the firing-time lookup table by simulation (Gambone sec. II) "
        "and compare tables with the paper's Tables 6 and 7.",
    )
    cmds = lookup.add_subparsers(dest="lookup_command", metavar="ACTION",
                                 parser_class=type(lookup))
    cmds.required = True

    gen = cmds.add_parser(
        "generate", help="fly the 26 rate cases and write the lookup table CSV",
        description="Fly the nominal vehicle from rest with each of the 26 rate commands of "
        "Table 3, fire whole 40 ms cycles until the rate reaches the command, keep the cycle "
        "count whose measured end rate is nearest, verify the table open loop and check rate "
        "damping.  Writes TABLE.csv and TABLE_settling.csv (or --settling-out).",
    )
    gen.add_argument("--out", required=True, metavar="TABLE.csv",
                     help="table to write (missing parent directories are created)")
    gen.add_argument("--settling-out", metavar="CSV",
                     help="settling/damping companion CSV (default: <out stem>_settling.csv)")
    gen.add_argument("--overwrite", action="store_true",
                     help="replace TABLE.csv and the settling CSV if they exist (an existing file "
                          "is never replaced without it, even an earlier generated table: it may "
                          "have been edited by hand)")
    gen.add_argument("--compare-with", choices=("table6", "table7", "none"), default="table6",
                     help="paper table to summarise the comparison against (default table6)")
    gen.set_defaults(func=run_generate)

    cmp_ = cmds.add_parser(
        "compare", help="compare a lookup table with the paper's Table 6 or 7, case by case",
        description="Print, per case, whether the same jets fire and the firing time per "
        "axis of TABLE and of the paper's table, with the difference in control cycles.",
    )
    cmp_.add_argument("--table", metavar="TABLE.csv",
                      help="table to compare (default: the packaged generated table)")
    cmp_.add_argument("--which", choices=("table6", "table7"), default="table6",
                      help="paper table (default table6, the original)")
    cmp_.set_defaults(func=run_compare)


def run_generate(args: argparse.Namespace) -> int:
    from rcsim.analysis.output import check_out_file, make_parents, remove_parents
    from rcsim.lookup.table_generation import compare_tables, generate_table
    from rcsim.models.atomic import atomic_write
    from rcsim.models.tables import load_lookup_table

    # Both outputs are checked before the 26 flights, not after.
    out = check_out_file(args.out, overwrite=args.overwrite, parameter="out")
    settling = check_out_file(
        args.settling_out or out.with_name(f"{out.stem}_settling.csv"),
        overwrite=args.overwrite, parameter="settling_out")
    if settling == out:
        raise InputError(f"--settling-out {settling}: is the table itself (--out)")
    gen = generate_table()
    frame = gen.settling_frame()
    created = make_parents(out) + make_parents(settling)
    try:
        # Each file is complete or absent (atomic rename), never half written.
        atomic_write(out, lambda tmp: gen.table.to_csv(tmp))
        atomic_write(settling, lambda tmp: frame.to_csv(tmp, index=False))
    except BaseException:
        remove_parents(created)
        raise
    print(f"wrote {out} (26 cases) and {settling}")
    print(f"rate damping: equal firing times on the opposing jets in "
          f"{int(gen.damping_equal.sum())}/26 cases")
    if args.compare_with != "none":
        cmp_ = compare_tables(gen.table, load_lookup_table(which=args.compare_with))
        print(f"vs paper {args.compare_with}: jets agree in {int(cmp_.jets_agree.sum())}/26 "
              f"cases; times within one cycle in {int(cmp_.within_one_cycle.sum())}/26; "
              f"identical in {int((cmp_.filter(like='diff_cycles') == 0).all(axis=1).sum())}/26")
    return 0


def run_compare(args: argparse.Namespace) -> int:
    import pandas as pd

    from rcsim.lookup.pattern_recognition import load_default_table
    from rcsim.lookup.table_generation import compare_tables
    from rcsim.models.tables import load_lookup_table

    if args.table is not None and not Path(args.table).is_file():
        raise InputError(f"--table {args.table}: file not found")
    table = load_default_table() if args.table is None else load_lookup_table(args.table)
    frame = compare_tables(table, load_lookup_table(which=args.which))
    with pd.option_context("display.width", 200, "display.max_columns", 20):
        print(frame.to_string(index=False))
    print(f"jets agree: {int(frame.jets_agree.sum())}/26; within one cycle: "
          f"{int(frame.within_one_cycle.sum())}/26")
    return 0
