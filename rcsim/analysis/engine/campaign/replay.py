"""Re-fly one run of a finished (or partial) campaign alone, with its full history and plots.

A run is a function of the spec and its run id only, so the replay is the campaign's run; the
replayed outcomes are compared with its row of ``runs.parquet`` (when present).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from rcsim.analysis.engine import runs_table
from rcsim.analysis.engine.campaign import results as R
from rcsim.analysis.engine.campaign.chunk import fly_runs, tabulate
from rcsim.analysis.engine.campaign.spec import parse_dict
from rcsim.analysis.engine.output import check_out_dir
from rcsim.models.errors import InputError

COMMAND = (
    "campaign replay"  # recorded in a replay directory's marker (rcsim.analysis.engine.output)
)


def load_campaign_spec(campaign: Path):
    manifest = R.read_manifest(campaign)
    if manifest is None:
        raise InputError(
            f"{campaign}: not a campaign directory (no readable {runs_table.MANIFEST})"
        )
    return parse_dict(manifest["spec"], source=str(campaign / runs_table.MANIFEST), base_dir=None)


def replay(
    campaign: str | Path, run_id: int, out: str | Path | None = None, *, overwrite: bool = False
) -> dict:
    """Re-fly run ``run_id`` of ``campaign`` and write its history
    (see :func:`rcsim.analysis.engine.flight.write_flight`).

    Parameters
    ----------
    campaign : path
        The campaign directory.
    run_id : int
        0 .. runs - 1.
    out : path, optional
        Output directory; default ``campaign/replays/run-NNNNNNN``.
    overwrite : bool
        Replace ``out`` if it holds an earlier replay's outputs (anything else is refused).

    Returns
    -------
    dict
        ``out`` (directory written), ``row`` (the replayed runs.parquet row as a dict),
        ``matches`` (True/False if the campaign row exists, else None).
    """
    from rcsim.analysis.engine.flight import write_flight

    campaign = Path(campaign)
    spec = load_campaign_spec(campaign)
    if not 0 <= run_id < spec.n_runs:
        raise InputError(
            f"{run_id}: the campaign has runs 0..{spec.n_runs - 1}",
            parameter="run_id",
            value=run_id,
        )
    out = Path(out) if out is not None else campaign / "replays" / f"run-{run_id:07d}"
    # Everything that can be refused is refused before the flight: the output, and the stored
    # row the replay is compared with (a damaged runs.parquet is named, not met after flying).
    check_out_dir(out, COMMAND, overwrite=overwrite)
    stored = _stored_row(campaign, run_id)
    case = spec.case_of(run_id)
    ids = np.array([run_id])
    history, dispersed = fly_runs(spec, ids)
    row = tabulate(spec, history, dispersed)
    title = f"{spec.controller} {spec.cases[case].name} run {run_id}"
    write_flight(
        history,
        out,
        title=title,
        vehicle=spec.vehicle,
        command=COMMAND,
        overwrite=overwrite,
    )
    matches = None
    if stored is not None and len(stored) == 1:
        matches = list(stored.columns) == list(row.columns) and bool(
            stored.reset_index(drop=True).equals(row)
        )
    return {
        "out": out,
        "row": row.iloc[0].to_dict(),
        "matches": matches,
        "case": spec.cases[case].name,
    }


def _stored_row(campaign: Path, run_id: int) -> pd.DataFrame | None:
    """Run ``run_id``'s row of the campaign's runs.parquet (None while the campaign has not
    assembled it); a file that cannot be read is an :class:`InputError` naming it."""
    runs_path = campaign / runs_table.RUNS
    if not runs_path.exists():
        return None
    try:
        stored = pd.read_parquet(runs_path, filters=[("run_id", "==", run_id)])
    except (OSError, ValueError) as exc:  # pyarrow's ArrowInvalid is a ValueError
        raise InputError(
            f"{runs_path}: cannot be read ({str(exc).splitlines()[0]}); the replay is "
            "compared with its row",
            parameter="campaign",
            value=str(campaign),
        ) from None
    return stored.rename(columns=R.RENAMED_COLUMNS)  # a campaign older than a rename
