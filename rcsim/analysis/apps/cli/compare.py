"""``rcsim compare controllers``: two controllers back to back on a campaign's runs.

``rcsim compare controllers SPEC --a NAME --b NAME [--a-param K=V] [--b-param K=V] --out DIR``
flies every run of the campaign spec with each controller (a built-in, a plug-in
``plugin:...``, C flight code ``library:...``; :mod:`rcsim.analysis.apps.back_to_back`).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from rcsim.lookup.c_library import LIBRARY_PREFIX
from rcsim.models.errors import InputError

COMMAND = "compare controllers"  # recorded in the output directory's marker


def register(sub) -> None:
    group = sub.add_parser(
        "compare",
        help="fly two controllers back to back on the same dispersed runs",
        description="Back-to-back tests of flight software.",
    )
    inner = group.add_subparsers(dest="compare_command", metavar="COMMAND", required=True)
    p = inner.add_parser(
        "controllers",
        help="fly two controllers on a campaign's runs; first divergence per run, outcomes",
        description="Fly every run of the campaign spec SPEC (its vehicle, seed, cases and "
        "dispersions) with controller A and controller B: run i draws the same vehicle for "
        "both, so both flights are identical until the first cycle the two command "
        "differently.  Writes DIR/divergence.csv (per run: the first divergent cycle, time, "
        "jet, both on-times, the navigation errors there; cycles differing; failures and "
        "propellant of each), DIR/summary.json and DIR/summary.md (the earliest divergence; "
        "failures paired by the exact McNemar test; the propellant difference with its t 95 "
        "%% interval).  docs/flight_software.md.",
    )
    p.add_argument("spec", metavar="SPEC", help="campaign spec (TOML); its [controller] is ignored")
    for side in ("a", "b"):
        p.add_argument(
            f"--{side}",
            required=True,
            metavar="NAME",
            help=f"controller {side.upper()}: a built-in (lookup uses the spec's table), "
            "plugin:MODULE:FACTORY or library:PATH",
        )
        p.add_argument(
            f"--{side}-param",
            action="append",
            default=[],
            metavar="KEY=VALUE",
            help=f"a parameter of controller {side.upper()} (a plug-in's; repeatable)",
        )
    p.add_argument("--out", required=True, metavar="DIR", help="output directory (created)")
    p.add_argument(
        "--overwrite", action="store_true", help="replace DIR if an earlier comparison wrote it"
    )
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from rcsim.analysis.apps import back_to_back as btb
    from rcsim.analysis.apps.cli.maneuver import plugin_params
    from rcsim.analysis.engine.campaign.spec import load_spec
    from rcsim.analysis.engine.output import atomic_dir, check_out_dir
    from rcsim.lookup.registry import check_controller_name, is_plugin

    sides = []
    for side in ("a", "b"):
        name, pairs = getattr(args, side), getattr(args, f"{side}_param")
        try:
            check_controller_name(name)
        except InputError as exc:
            raise InputError(f"--{side}: {exc}") from None
        if pairs and not is_plugin(name):
            raise InputError(f"--{side}-param is only for a plug-in controller, not {name!r}")
        sides.append(btb.Side(name, plugin_params(pairs)))
    spec = load_spec(args.spec)
    out = check_out_dir(args.out, COMMAND, overwrite=args.overwrite, inputs={"SPEC": args.spec})
    a, b = (s.spec_for(spec) for s in sides)  # both build before any flight (one line if not)
    del a, b
    if any(s.name.startswith(LIBRARY_PREFIX) for s in sides):
        # C flight code may crash its process: the comparison flies in a child.
        from rcsim.analysis.engine.isolated import run_isolated

        result = run_isolated(btb.compare_item, (spec, *sides), who="compare controllers")
    else:
        result = btb.compare(spec, *sides, progress=_progress(spec.n_runs))
    with atomic_dir(out, COMMAND, overwrite=args.overwrite) as tmp:
        btb.write(result, Path(tmp))
    for line in btb.summary_lines(result["summary"]):
        print(line)
    print(f"outputs in {out}/: divergence.csv, summary.json, summary.md")
    return 0


def _progress(total: int):
    """A runs/s and ETA bar on a terminal, nothing in a log."""
    if not sys.stderr.isatty():
        return None
    from tqdm import tqdm

    bar = tqdm(total=total, unit="run", desc="back to back", file=sys.stderr)
    return bar.update
