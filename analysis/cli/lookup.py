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

    ref = cmds.add_parser(
        "refine", help="make a lookup table robust to the Table 5 dispersions (automated Table 7)",
        description="Fly the dispersed runs of every rate case (Table 5 dispersions, the "
        "campaign's failure threshold), and where runs fail or need repeated firings, search "
        "the firing times (whole 40 ms cycles per axis of the entry) that minimise failures "
        "first and repeated firings second, over the same dispersed runs for every candidate. "
        "Then fly the old and refined tables on a fresh seed the search never saw.  Writes "
        "OUT.csv (a table for --table), OUT_changelog.csv and OUT_plots/.",
    )
    ref.add_argument("--table", required=True, metavar="IN.csv",
                     help="table to refine: a CSV (rcsim or paper layout) or table6 / table7")
    ref.add_argument("--runs", dest="runs_per_case", type=int, default=200, metavar="N",
                     help="dispersed runs per case (default 200)")
    ref.add_argument("--seed", type=int, default=1, metavar="S",
                     help="search seed: run i of case c draws from SeedSequence(S, "
                          "spawn_key=(c*N+i,)), as in `rcsim campaign run` (default 1)")
    ref.add_argument("--fresh-seed", type=int, metavar="S2",
                     help="held-out seed for the before/after check (default S + 1)")
    ref.add_argument("--cases", type=int, nargs="+", metavar="CASE",
                     help="rate cases (1-26) to refine (default: all)")
    ref.add_argument("--duration-s", type=float, default=20.0,
                     help="simulated time of every run [s] (default 20, as campaigns)")
    ref.add_argument("--max-iterations", type=int, default=8, metavar="K",
                     help="most rounds of candidates (default 8)")
    ref.add_argument("--out", required=True, metavar="OUT.csv",
                     help="refined table to write (missing parent directories are created)")
    ref.add_argument("--overwrite", action="store_true",
                     help="replace OUT.csv, its changelog and plots if they exist")
    ref.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                     help="progress bars on stderr (default: only on a terminal)")
    ref.set_defaults(func=run_refine)


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

    table = load_default_table() if args.table is None else load_lookup_table(args.table)
    frame = compare_tables(table, load_lookup_table(which=args.which))
    with pd.option_context("display.width", 200, "display.max_columns", 20):
        print(frame.to_string(index=False))
    print(f"jets agree: {int(frame.jets_agree.sum())}/26; within one cycle: "
          f"{int(frame.within_one_cycle.sum())}/26")
    return 0


def run_refine(args: argparse.Namespace) -> int:
    from rcsim.analysis.refinement.outputs import check_outputs, run_refinement, write_refinement
    from rcsim.models.tables import load_lookup_table

    table = load_lookup_table(args.table)
    # OUT.csv, OUT_changelog.csv and OUT_plots/ are checked before any flight; --overwrite
    # replaces all three.
    out = check_outputs(args.out, overwrite=args.overwrite)["table"]
    fresh = args.seed + 1 if args.fresh_seed is None else args.fresh_seed
    cases = None
    if args.cases is not None:
        bad = [c for c in args.cases if c not in set(int(c) for c in table.case)]
        if bad:
            raise InputError(f"--cases {bad[0]}: no such rate case; cases are 1..{len(table.case)}")
        cases = [list(table.case).index(c) for c in args.cases]
    ref = run_refinement(table, runs_per_case=args.runs_per_case, seed=args.seed, fresh_seed=fresh,
                         cases=cases, duration_s=args.duration_s,
                         max_iterations=args.max_iterations, progress=args.progress)
    paths = write_refinement(ref, out, overwrite=args.overwrite)
    log = ref.changelog
    print(f"refined {args.table}: {int(log['changed'].sum())} of {len(log)} cases changed "
          f"({ref.result.runs_flown} runs flown in the search, {args.runs_per_case} per case)")
    for _, row in log[log["changed"]].iterrows():
        moves = ", ".join(f"{a} {row[f'{a}_old_s']:.2f}->{row[f'{a}_new_s']:.2f} s"
                          for a in ("roll", "pitch", "yaw") if row[f"{a}_change_cycles"])
        print(f"  case {int(row['case']):2d}: {moves}")
    for seed_name, seed in (("search", args.seed), ("fresh", fresh)):
        print(f"seed {seed} ({seed_name}): failed runs {int(log[f'failed_{seed_name}_before'].sum())}"
              f" -> {int(log[f'failed_{seed_name}_after'].sum())}, repeated-firing runs "
              f"{int(log[f'repeated_{seed_name}_before'].sum())} -> "
              f"{int(log[f'repeated_{seed_name}_after'].sum())}")
    print("wrote " + ", ".join(str(p) for p in paths.values()))
    return 0
