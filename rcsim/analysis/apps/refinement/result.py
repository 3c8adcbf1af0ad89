"""A refinement with its held-out check: what :func:`~rcsim.analysis.apps.refinement.outputs.
run_refinement` returns, what the outputs and plots are written from."""

from __future__ import annotations

from dataclasses import dataclass

import pandas as pd

from rcsim.analysis.apps.refinement.search import RefineResult
from rcsim.lookup.table_plugins import TablePlugin
from rcsim.models.tables import LookupTable
from rcsim.spacecraft.vehicle import Vehicle


@dataclass
class Refinement:
    """A refinement with its held-out check.

    Attributes
    ----------
    original : LookupTable
        The table refined.
    result : RefineResult
    fresh_before, fresh_after : DataFrame
        Per searched case on the fresh seed: ``failed, repeated, runs``.
    changelog : DataFrame
    seed, fresh_seed, runs_per_case : int
    duration_s : float
        Simulated time of every run [s].
    comparison : DataFrame, optional
        The held-out seed per table (the original, the refined and, when the original is the
        packaged Table 6, the paper's Table 7): :func:`comparison_frame`.
    confirm_seed : int, optional
        The confirmation seed (None: the search gate alone).
    vehicle : Vehicle
        The vehicle flown (:func:`~rcsim.analysis.apps.refinement.parameters.refinement_vehicle`).
    table_file : str
        The original table's file as the campaigns name it (a channel table's), or "default".
    regressions : str
        The held-out check of every case: each case significantly worse with the refined
        table as searched, and the changed rows that cause it ("" when none;
        :mod:`~rcsim.analysis.apps.refinement.regressions`).
    further : dict, optional
        When rows causing a regression were dropped: the further seed's check of the final
        table (``seed``, ``dropped_rows`` (case numbers), ``comparison``, ``failed_before``,
        ``failed_after``, ``runs``, ``regressions``).
    plugin : TablePlugin, optional
        The plug-in that flew every table (None: the built-in lookup controller).
    """

    original: LookupTable
    result: RefineResult
    fresh_before: pd.DataFrame
    fresh_after: pd.DataFrame
    changelog: pd.DataFrame
    seed: int
    fresh_seed: int
    runs_per_case: int
    duration_s: float
    vehicle: Vehicle
    comparison: pd.DataFrame | None = None
    confirm_seed: int | None = None
    table_file: str = "default"
    regressions: str = ""
    further: dict | None = None
    plugin: TablePlugin | None = None

    @property
    def table(self) -> LookupTable:
        return self.result.table
