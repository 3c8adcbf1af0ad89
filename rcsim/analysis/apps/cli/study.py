"""``rcsim study``: research studies reproduced from papers.

``rcsim study noisy-sensor`` runs the single-axis noisy-sensor Monte Carlo of Pittella &
Sands (Sensors 2023) over six control architectures; see
:mod:`rcsim.analysis.apps.studies.noisy_sensor`. Flags are named after the library's parameters
(``--noise-var`` fills ``noise_var``), so a library error about a parameter is reported under its
flag.
"""

from __future__ import annotations

import argparse


def register(subparsers) -> None:
    """Add the ``study`` command group and its ``noisy-sensor`` sub-command.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        The top-level ``rcsim`` sub-command action.
    """
    study = subparsers.add_parser(
        "study",
        help="reproduce a published control study",
        description="Reproduce a published control study and write its tables and figures.",
    )
    studies = study.add_subparsers(dest="study", metavar="STUDY", parser_class=type(study))
    studies.required = True
    _add_noisy_sensor(studies)
    from rcsim.analysis.apps.cli.study_dai import register_dai

    register_dai(studies)


def _add_noisy_sensor(studies) -> None:
    parser = studies.add_parser(
        "noisy-sensor",
        help="six single-axis architectures under sensor noise (Pittella & Sands 2023)",
        description=(
            "Monte Carlo of a nondimensional rest-to-rest rotation (1 unit in 1 time unit) "
            "flown by P+V, open-loop optimal, RTOC, two double-integrator patching filters "
            "and the control-law-inversion filter, with Gaussian noise on measured angle "
            "and rate and a uniform inertia error.  Writes summary.csv (Table 1 + wall "
            "time), percent.csv (Table 2), runs.parquet and scatter.png (Figure 4).  "
            "--noise-var 0 --inertia-spread 0 gives the deterministic results."
        ),
    )
    parser.add_argument(
        "--runs",
        type=int,
        default=1000,
        metavar="N",
        help="Monte Carlo runs per architecture, >= 2 (default 1000)",
    )
    parser.add_argument(
        "--seed",
        type=int,
        default=0,
        metavar="S",
        help="root seed >= 0; run i uses SeedSequence(S, spawn_key=(i,)) (default 0)",
    )
    parser.add_argument(
        "--noise-var",
        type=float,
        default=1e-4,
        metavar="V",
        help="variance of the noise on measured angle and on measured rate, "
        "nondimensional (default 1e-4)",
    )
    parser.add_argument(
        "--inertia-spread",
        type=float,
        default=0.1,
        metavar="F",
        help="inertia factor drawn uniformly in [1-F, 1+F], F in [0, 1) (default 0.1)",
    )
    parser.add_argument(
        "--out",
        required=True,
        metavar="DIR",
        help="output directory (created; an existing one is refused unless it "
        "holds an earlier study's outputs and --overwrite is given)",
    )
    parser.add_argument(
        "--overwrite",
        action="store_true",
        help="replace DIR if it holds an earlier `rcsim study noisy-sensor`'s outputs",
    )
    parser.set_defaults(func=_run_noisy_sensor)


def _run_noisy_sensor(args: argparse.Namespace) -> int:
    # Imported here so that `rcsim --help` does not pay for pandas and matplotlib.
    from rcsim.analysis.apps.studies import noisy_sensor as ns
    from rcsim.analysis.engine.output import check_out_dir

    cfg = ns.StudyConfig(
        runs=args.runs, seed=args.seed, noise_var=args.noise_var, inertia_spread=args.inertia_spread
    )
    check_out_dir(args.out, ns.OUTPUT_COMMAND, overwrite=args.overwrite)  # before the work
    result = ns.run_study(cfg)
    out = ns.write_outputs(result, args.out, overwrite=args.overwrite)
    print(ns.format_summary(result.summary))
    print(f"wrote {', '.join(ns.OUTPUT_FILES)} to {out}")
    return 0
