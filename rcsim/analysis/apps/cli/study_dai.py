"""``rcsim study dai``: the continuous-torque DAI study (Wilt & Sands 2022; Smeresky & Rizzo 2020).

Argument parsing and error reporting only; the work is
:func:`rcsim.analysis.apps.studies.dai.run_dai_study`.  Flags are named after its parameters
(``--runs`` fills ``runs``), so a library error about a parameter is reported under its flag.
Wire it with ``register_dai(studies)`` inside ``rcsim study``'s sub-command group.
"""

from __future__ import annotations

import argparse

# Scenario names, repeated here so that `rcsim --help` does not import the study (MuJoCo,
# pandas, matplotlib); tests/analysis/apps/studies/test_dai_study.py checks they match SCENARIOS.
SCENARIO_NAMES = (
    "wilt_yaw30",
    "wilt_yaw30_disturbed",
    "wilt_yaw100_damage",
    "smeresky_yaw30",
    "smeresky_yaw30_coarse",
)


def register_dai(studies) -> None:
    """Add ``dai`` to the ``rcsim study`` sub-command action ``studies``."""
    parser = studies.add_parser(
        "dai",
        help="continuous-torque FFD / FB / DAI attitude control (Wilt & Sands 2022; "
        "Smeresky & Rizzo 2020)",
        description=(
            "Fly the 30 deg and 100 deg yaw scenarios of Wilt & Sands (nominal, with gravity "
            "gradient and drag at 150 km, with a sudden inertia change) with FFD+FB and the "
            "hybrid FFD+FB+DAI in three readings of its learning law (the papers': the feedback "
            "correction, learned and added to the command; the total torque, learned into "
            "the feedforward's inertia; and Wilt & Sands App. B's Theta_dot, the feedback "
            "integrated into the feedforward's inertia, dTheta/dt = g Phi_d^T u_fb with the "
            "gain g of rcsim/models/dai/parameters.csv), and the 30 deg yaw of Smeresky & "
            "Rizzo with FFD, FB and "
            "FFD+FB at 0.001 s and 0.01 s, through three CMGs in MuJoCo.  Writes summary.csv "
            "(mean tracking error, its standard deviation, control effort, wall time), "
            "improvement.csv (Table 9), montecarlo.csv and the time-history plots."
        ),
    )
    parser.add_argument(
        "--out",
        required=True,
        metavar="DIR",
        help="output directory (created; an existing one is refused unless it "
        "holds an earlier `rcsim study dai` output and --overwrite is given)",
    )
    parser.add_argument(
        "--overwrite",
        action="store_true",
        help="replace DIR if it holds an earlier `rcsim study dai` output",
    )
    parser.add_argument(
        "--scenario",
        dest="scenarios",
        action="append",
        choices=SCENARIO_NAMES,
        metavar="NAME",
        help="fly only this scenario (repeatable; default all): " + ", ".join(SCENARIO_NAMES),
    )
    parser.add_argument(
        "--runs",
        type=int,
        default=0,
        metavar="N",
        help="Monte Carlo runs per scenario and method besides the nominal one, >= 0 (default 0)",
    )
    parser.add_argument(
        "--seed",
        type=int,
        default=0,
        metavar="S",
        help="root seed >= 0; run i uses SeedSequence(S, spawn_key=(i,)) (default 0)",
    )
    parser.set_defaults(func=_run_dai)


def _run_dai(args: argparse.Namespace) -> int:
    # Imported here so that `rcsim --help` does not pay for MuJoCo, pandas and matplotlib.
    from rcsim.analysis.apps.studies.dai import run_dai_study

    scenarios = tuple(dict.fromkeys(args.scenarios)) if args.scenarios else None
    summary = run_dai_study(
        args.out,
        scenarios=scenarios,
        runs=args.runs,
        seed=args.seed,
        overwrite=args.overwrite,
        progress=lambda what: print(f"flying {what}", flush=True),
    )
    cols = [
        "scenario",
        "method",
        "mean_tracking_error_deg",
        "tracking_error_std_deg",
        "control_effort_n_m_s",
        "wall_time_s",
    ]
    print(summary[cols].to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    print(f"wrote summary.csv, improvement.csv, montecarlo.csv and plots to {args.out}")
    return 0
