"""The analyst's loop: campaign -> failure drivers -> refined table -> fresh campaign -> report.

``rcsim loop`` (and ``make run``) on defaults: a Table 5 campaign of the 26 rate cases flown
with the paper's Table 6, its failure-driver analysis, refinement of the table, the refined
table re-flown on a fresh seed, and one ``report.html`` with the before/after.

On a vehicle file whose jets torque several axes (``--vehicle canted16``) the table refined is
generated first (stage ``generate``: a channel table and its recipe, :mod:`rcsim.lookup.channels`),
then the same stages run on it.

Every stage writes its own sub-directory of ``DIR`` completely or not at all, and the loop
records each finished stage in ``DIR/loop.json``: a loop killed in its tenth minute resumes
(``resume=True``) from the last finished stage, and the campaigns resume chunk by chunk.
"""

from __future__ import annotations

import json
import time
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path

import numpy as np
import pandas as pd

from rcsim.analysis.apps.loop.files import GENERATE, spec_text, table_file
from rcsim.analysis.apps.loop.rare import check_rare_settings, rare_stage
from rcsim.analysis.apps.refinement.parameters import (
    check_parameters,
    held_out_seed,
    load_refinable_table,
    refinement_spec,
    refinement_vehicle,
)
from rcsim.analysis.apps.refinement.search import SEARCH_RUNS_PER_CASE
from rcsim.analysis.engine.campaign import results as campaign_results
from rcsim.analysis.engine.campaign.runner import run_campaign
from rcsim.analysis.engine.campaign.spec import load_spec
from rcsim.analysis.engine.memory import give_back_free_memory
from rcsim.analysis.engine.output import check_out_dir, directory_owner, output_lock, write_marker
from rcsim.analysis.engine.output_places import writing_inside
from rcsim.analysis.results.scoring import SCORED_COLUMNS
from rcsim.models.atomic import atomic_write
from rcsim.models.errors import InputError
from rcsim.models.tables import N_CASES, PAPER_LOOKUP_TABLES, load_lookup_table
from rcsim.spacecraft.vehicle import Vehicle

COMMAND = "loop"
STATE = "loop.json"
#: Where the loop's ``control`` overrides come from, in messages and the profile's source.
CONTROL_FROM = "the loop's --control"
#: Stages in order, each a sub-directory (or file) of DIR.
STAGES = ("campaign_before", "drivers", "refine", "campaign_after", "check", "rare", "report")


def stages_of(settings: LoopSettings) -> tuple:
    """The loop's stages: :data:`STAGES`, after ``generate`` when the table is generated."""
    return (("generate",) if settings.table == GENERATE else ()) + STAGES


@dataclass(frozen=True)
class LoopSettings:
    """What the loop flies (defaults: ``make run``).

    Attributes
    ----------
    table : str or None
        Table to refine: ``"table6"`` / ``"table7"`` (the paper's), a CSV path, or
        ``"generate"`` (generated for the vehicle by the loop's first stage).  None (the
        default): ``"table6"``, or ``"generate"`` on a vehicle whose jets do not play Table
        2's roles (its table is a channel table).
    runs_per_case : int
        Dispersed runs per rate case, for the campaigns and the refinement search.
    seed : int
        Campaign and search seed; run i draws from ``SeedSequence(seed, spawn_key=(i,))``.
    fresh_seed : int
        Held-out seed: the refined table is re-flown on it (default ``seed + 1``).
    duration_s : float
        Simulated time of every run [s].
    permutations : int
        Label permutations of the driver analysis's p-values.
    max_iterations : int
        Most rounds of the refinement search.
    search_runs_per_case : int
        Runs per case the refinement search flies (the first of the "before" campaign's, the
        same draws); the refined table is then flown on every run of the held-out seed.
    vehicle : str or None
        A vehicle file (absolute path) or packaged vehicle name the campaigns and the search
        fly; None: the paper's.  A paper table needs Table 2's jet roles; a channel table must
        have been solved for this vehicle file.
    control : dict or None
        Overrides of the vehicle's flight-software profile (``[control]`` keys:
        ``--control KEY=VALUE``), written into every campaign spec of the loop.
    max_propellant_rise_pct : float
        A change raising a case's mean propellant by more than this [%] must pay for it with
        failures (:mod:`rcsim.analysis.apps.refinement.propellant`); stated in the report.
    plots : bool
        The campaigns' per-case plots (about 4.5 s per campaign on 2 cores, whatever its
        size); without them the report's Figs 9-10 section says the figures were not made.
    rare_budget, rare_cases : int
        The rare-event stage (:mod:`~rcsim.analysis.apps.loop.rare`): most runs per case (0,
        the default: off) and most cases estimated.
    drop_regressions : bool
        The check stage's held-out check of every case: a changed row that makes some case
        significantly worse on the held-out seed goes back to the original row, and the
        original and the final table are flown again on a further seed (one past every
        other), which the report and the changelog state (:mod:`~rcsim.analysis.apps.
        refinement.regressions`).  False: regressions are reported, the table kept.
    controller : str or None
        A plug-in that flies the table instead of rcsim's lookup controller (``plugin:...``,
        ``library:...`` or a registered name) and declares its table parameter
        (:mod:`rcsim.lookup.table_plugins`): every campaign and every candidate of the
        refinement is flown by it.  None: rcsim's lookup controller.
    controller_params : dict or None
        The plug-in's other parameters (its table's is the loop's to set).
    """

    table: str | None = None
    runs_per_case: int = 100
    seed: int = 1
    fresh_seed: int | None = None
    duration_s: float = 20.0
    permutations: int = 200
    max_iterations: int = 8
    search_runs_per_case: int = SEARCH_RUNS_PER_CASE
    max_propellant_rise_pct: float = 10.0
    plots: bool = True
    vehicle: str | None = None
    control: dict | None = None
    rare_budget: int = 0
    rare_cases: int = 3
    drop_regressions: bool = True
    controller: str | None = None
    controller_params: dict | None = None

    def flown_vehicle(self) -> Vehicle:
        """The vehicle the loop flies, resolved from its settings (the file, the overrides)."""
        return Vehicle.load(self.vehicle, control=self.control, control_from=CONTROL_FROM)

    def __post_init__(self):
        # The refinement's and the driver analysis's own checks: one rule for each.
        from rcsim.analysis.results.drivers.pipeline import Settings

        check_parameters(
            runs_per_case=self.runs_per_case,
            seed=self.seed,
            fresh_seed=self.held_out_seed,
            duration_s=self.duration_s,
            max_iterations=self.max_iterations,
            search_runs_per_case=self.search_runs_per_case,
            max_propellant_rise_pct=self.max_propellant_rise_pct,
        )
        Settings(n_permutations=self.permutations, random_state=self.seed)
        check_rare_settings(self.rare_budget, self.rare_cases)
        self._check_controller()
        from rcsim.lookup.generation import is_coupled

        try:
            vehicle = Vehicle.load(self.vehicle)
        except InputError as exc:
            raise InputError(str(exc), parameter="vehicle", value=self.vehicle) from None
        # An override's error names the overrides (their origin starts the message), not the
        # vehicle: the file itself loaded.
        vehicle = vehicle.with_control(self.control, CONTROL_FROM)
        coupled = is_coupled(vehicle)
        table_name = self.table if self.table is not None else (GENERATE if coupled else "table6")
        object.__setattr__(self, "table", table_name)
        if coupled and self.table in PAPER_LOOKUP_TABLES:
            raise InputError(
                f"{self.table!r} is the paper's table, for its jet map (Table 2), but the jets "
                f"of {self.vehicle} torque several axes; leave the table out (or give "
                f"{GENERATE!r}) to generate the vehicle's channel table first",
                parameter="table",
                value=self.table,
            )
        if (
            self.vehicle is not None
            or self.control is not None
            or self.table not in (*PAPER_LOOKUP_TABLES, GENERATE)
        ):
            # The campaigns' own checks on the vehicle and the table (a file that loads, jets
            # that play the table's roles, a channel table solved for this vehicle file),
            # before any directory is made.  A table still to generate is checked when made.
            table = "default" if table_name in PAPER_LOOKUP_TABLES else table_name
            try:
                refinement_spec(
                    runs_per_case=1,
                    seed=0,
                    duration_s=self.duration_s,
                    vehicle=vehicle,
                    source=str(self.vehicle or self.table),
                    # A table still to generate: the vehicle alone (the allocator flies any).
                    table=table if table != GENERATE else "default",
                    controller="allocator" if table == GENERATE else "lookup",
                )
            except InputError as exc:
                which = "vehicle" if self.vehicle is not None else "table"
                text = str(exc)
                # The spec's message names its source (here the vehicle) and the key, then the
                # vehicle file again ("FILE: vehicle: FILE cannot fly ..."): under --vehicle
                # the file once is enough.
                again = f"{self.vehicle}: vehicle: "
                if which == "vehicle" and text.startswith(again):
                    text = text[len(again) :]
                raise InputError(text, parameter=which, value=getattr(self, which)) from None

    def _check_controller(self) -> None:
        """A plug-in must declare the table it flies, and leave that parameter to the loop
        (the whole check, a probe flight on the table, is the refine stage's)."""
        if self.controller is None:
            if self.controller_params:
                raise InputError(
                    "is only for a plug-in controller (--controller)",
                    parameter="controller_params",
                    value=self.controller_params,
                )
            return
        from rcsim.lookup.registry import is_plugin
        from rcsim.lookup.table_plugins import declared_table_param

        if not is_plugin(self.controller):
            raise InputError(
                f"{self.controller!r}: the loop flies its table with rcsim's lookup controller "
                "(the default) or a plug-in that declares its table parameter",
                parameter="controller",
                value=self.controller,
            )
        try:
            key = declared_table_param(self.controller)
        except InputError as exc:
            raise InputError(str(exc), parameter="controller", value=self.controller) from None
        if key is None:
            raise InputError(
                f"{self.controller!r} declares no lookup-table parameter, so the loop has no "
                "table of its to refine (docs/flight_software.md, 'Refining your table')",
                parameter="controller",
                value=self.controller,
            )
        if key in (self.controller_params or {}):
            raise InputError(
                f"{key!r} is the parameter the loop passes its table through; give the table "
                "as --table",
                parameter="controller_params",
                value=self.controller_params,
            )

    @property
    def held_out_seed(self) -> int:
        return held_out_seed(self.seed) if self.fresh_seed is None else self.fresh_seed

    @property
    def confirm_seed(self) -> int:
        """The refinement's confirmation seed (its second gate), neither of the others."""
        from rcsim.analysis.apps.refinement.parameters import confirmation_seed

        return confirmation_seed(self.seed, self.held_out_seed)


@dataclass
class LoopResult:
    """Where the loop wrote, and the time of each stage [s]."""

    out: Path
    report: Path
    stage_s: dict = field(default_factory=dict)
    summary: dict = field(default_factory=dict)


class _State:
    """``DIR/loop.json``: the settings and the stages already finished."""

    def __init__(self, out: Path, settings: LoopSettings, resume: bool):
        self.path = out / STATE
        wanted = asdict(settings)
        if resume and self.path.is_file():
            self.data = read_state(out)
            stored = _comparable(self.data.get("settings")) or {}
            ours = _comparable(wanted) or {}
            differ = [k for k in ours if stored.get(k) != ours[k]]
            if differ:
                what = "; ".join(f"{k} {stored.get(k)!r} there, {ours[k]!r} here" for k in differ)
                raise InputError(
                    f"{out}: was started with other settings ({what}); resume it with its own "
                    "settings, or choose another directory",
                    parameter="out",
                    value=str(out),
                )
            return  # as it was: saved again only when a stage finishes
        self.data = {
            "format": "rcsim-loop/1",
            "settings": wanted,
            "done": {},
            "code_version": campaign_results.code_version(),
            "started_utc": campaign_results.now_utc(),
        }
        self.save()

    def done(self, stage: str) -> bool:
        return stage in self.data["done"]

    def finish(self, stage: str, seconds: float, **info) -> None:
        self.data["done"][stage] = {"seconds": round(seconds, 2), **info}
        self.save()

    def save(self) -> None:
        atomic_write(
            self.path, lambda tmp: Path(tmp).write_text(json.dumps(self.data, indent=2) + "\n")
        )


def _defaults() -> dict:
    return {f.name: f.default for f in fields(LoopSettings)}


def _comparable(settings) -> dict | None:
    """Settings as they decide what is flown: the held-out seed, not how it was given; a
    setting an older loop.json lacks at its default (what that loop flew)."""
    if not isinstance(settings, dict):
        return None
    out = {**_defaults(), **settings}
    if out.get("fresh_seed") is None and isinstance(out.get("seed"), int):
        out["fresh_seed"] = held_out_seed(out["seed"])
    return out


def resumed_settings(out, given: dict) -> LoopSettings:
    """The settings of the loop in ``out`` (its ``loop.json``), for a resume.

    ``given`` holds the settings the user named explicitly; each must equal the loop's own
    (the error names the first that does not, with both values).
    """
    out = check_loop_dir(out, resume=True, overwrite=False)  # a loop's, not another's
    stored = _comparable(read_state(out)["settings"]) or {}
    for key, value in given.items():
        mine = _comparable({**stored, key: value}) or {}
        if mine.get(key) != stored.get(key):
            raise InputError(
                f"{value!r} differs from the loop's own {stored.get(key)!r} ({out / STATE}); "
                "omit it to resume with the loop's settings",
                parameter=key,
                value=value,
            )
    known = {f.name for f in fields(LoopSettings)}
    return LoopSettings(**{k: v for k, v in stored.items() if k in known})


def read_state(out: Path) -> dict:
    """``out/loop.json``, checked; :class:`InputError` naming the file if it is not one."""
    path = out / STATE
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise InputError(
            f"{path}: not a readable loop state file ({exc})", parameter="out", value=str(out)
        ) from None
    if not (
        isinstance(data, dict)
        and isinstance(data.get("settings"), dict)
        and isinstance(data.get("done"), dict)
    ):
        raise InputError(
            f"{path}: not a loop state file (no settings and stages)",
            parameter="out",
            value=str(out),
        )
    return data


def check_loop_dir(out, *, resume: bool, overwrite: bool) -> Path:
    """Check ``out`` before any work: new, or a loop directory to resume."""
    out = Path(out)
    if resume:
        if not (out / STATE).is_file():
            raise InputError(
                f"{out}: no {STATE} here to resume; start the loop without resume",
                parameter="out",
                value=str(out),
            )
        owner = directory_owner(out)
        if owner != COMMAND:
            raise InputError(
                f"{out}: was not written by `rcsim loop`"
                + (f" (it holds `rcsim {owner}` outputs)" if owner else ""),
                parameter="out",
                value=str(out),
            )
        read_state(out)
        return out.absolute()
    if overwrite:
        raise InputError(
            "a loop directory is resumed, never replaced: choose another directory",
            parameter="overwrite",
            value=True,
        )
    return check_out_dir(out, COMMAND)


def run_loop(
    settings: LoopSettings, out, *, resume: bool = False, progress: bool | None = None, echo=print
) -> LoopResult:
    """Run every stage of the loop into ``out`` (see the module docstring).

    Parameters
    ----------
    settings : LoopSettings
    out : path
        A new directory, or one to finish (``resume``).
    echo : callable
        Receives one line per finished stage (the CLI prints them).
    """
    table = None
    if settings.table != GENERATE:  # a table that does not load: before any work
        table = load_refinable_table(settings.table)
    out = check_loop_dir(out, resume=resume, overwrite=False)
    # Its stages write inside it (campaigns, the driver analysis, the refined table): the one
    # place outputs nest on purpose (rcsim.analysis.engine.output_places).
    with output_lock(out, COMMAND), writing_inside(out):
        return _run_stages(table, settings, out, resume, progress, echo)


def _run_stages(table, settings: LoopSettings, out: Path, resume: bool, progress, echo):
    out.mkdir(parents=True, exist_ok=True)
    write_marker(out, COMMAND)
    state = _State(out, settings, resume)
    stages = _Stages(out, settings, table, state, progress)
    flown = False
    for name in stages_of(settings):
        if state.done(name):
            echo(f"{name}: already done")
            continue
        flown = True
        t0 = time.perf_counter()
        info = getattr(stages, name)() or {}
        seconds = time.perf_counter() - t0
        # What the stage freed goes back to the system before the next stage's workers start
        # (the driver analysis alone left ~170 MB free in this process's heap and pyarrow's pool).
        give_back_free_memory()
        state.finish(name, seconds, **info)
        echo(f"{name}: done in {seconds:.1f} s" + "".join(f"; {k} {v}" for k, v in info.items()))
    if flown or "finished_utc" not in state.data:
        # A resume of a finished loop did nothing: its record keeps when it finished.
        state.data["finished_utc"] = campaign_results.now_utc()
        state.save()
    return LoopResult(
        out=out,
        report=stages.paths["report"],
        stage_s={k: v["seconds"] for k, v in state.data["done"].items()},
    )


class _Stages:
    """The loop's stages, one method each, named as in :data:`STAGES`; each returns the
    facts its line in ``loop.json`` and on the terminal reports."""

    def __init__(
        self, out: Path, settings: LoopSettings, table, state: _State, progress: bool | None
    ):
        self.out, self.settings, self._table = out, settings, table
        self.state, self.progress = state, progress
        # The vehicle, resolved once for every stage (its model compiled once per process).
        self.vehicle = settings.flown_vehicle()
        self.cases = np.arange(N_CASES)
        # How the campaigns name the table refined: the paper's by name, a file by its path
        # (the generated one in DIR).
        self.table_file = table_file(out, str(settings.table))  # resolved: never None
        self.paths = {
            "campaign_before": out / "campaign_before",
            "drivers": out / "drivers",
            "refined": out / "refined_table.csv",
            "search": out / "refine_search.json",
            "campaign_after": out / "campaign_after",
            "campaign_check": out / "campaign_check",
            "report": out / "report.html",
        }

    @property
    def table(self):
        """The table refined (the generated one read once the ``generate`` stage wrote it)."""
        if self._table is None:
            self._table = load_refinable_table(self.table_file)
        return self._table

    def generate(self) -> dict:
        """The vehicle's table: a channel table (and its recipe) for coupled jets."""
        from rcsim.analysis.engine.table_files import write_table_files
        from rcsim.lookup.generation import generate_table

        gen = generate_table(self.vehicle)
        path = Path(self.table_file)
        # One commit: the table, its recipe and companion, all or none.
        write_table_files(gen, path, path.with_name(f"{path.stem}_settling.csv"))
        kind = "jet table" if gen.table.recipe is None else "channel table (six axis channels)"
        return {"table": kind, "open_loop_max_err_deg_s": round(
            float(np.degrees(np.abs(gen.verify_rate_err_rad_s)).max()), 4
        )}  # fmt: skip

    @property
    def plugin(self):
        """The plug-in that flies the table (:class:`~rcsim.lookup.table_plugins.TablePlugin`,
        built and probed on the table once), or None: rcsim's lookup controller."""
        s = self.settings
        if s.controller is None:
            return None
        if getattr(self, "_plugin", None) is None:
            from rcsim.lookup.table_plugins import TablePlugin

            self._plugin = TablePlugin.for_refinement(
                s.controller, s.controller_params, self.vehicle, self.table
            )
        return self._plugin

    def _plugin_table(self, table_path: str) -> str:
        """The file a plug-in flies for ``table_path``: a paper table by name is written into
        DIR first (rcsim layout: a plug-in reads files, not rcsim's names)."""
        if table_path not in PAPER_LOOKUP_TABLES:
            return str(Path(table_path).resolve())  # a resumed loop reads it from anywhere
        path = (self.out / f"{table_path}.csv").resolve()
        if not path.exists():
            self.table.to_csv(path)
        return str(path)

    def _campaign(self, name: str, table_path: str, seed: int, plots: bool | None = None) -> dict:
        s = self.settings
        spec_file = self.out / f"spec_{name.split('_')[1]}.toml"
        if not spec_file.exists():
            flown: dict = {}
            if self.plugin is not None:
                flown = {
                    "controller": s.controller,
                    "controller_params": {
                        **self.plugin.params,
                        self.plugin.key: self._plugin_table(table_path),
                    },
                }
            text = spec_text(
                table=table_path,
                runs_per_case=s.runs_per_case,
                seed=seed,
                duration_s=s.duration_s,
                plots=s.plots if plots is None else plots,
                vehicle=self.vehicle,
                name_vehicle=s.vehicle is not None,
                **flown,
            )
            atomic_write(spec_file, lambda tmp: Path(tmp).write_text(text))
        report = run_campaign(
            load_spec(spec_file),
            self.paths[name],
            resume=self.paths[name].exists(),
            progress=self.progress,
            spec_file=str(spec_file),
        )
        return {"runs": report.counts.get("runs"), "failed": report.counts.get("failed")}

    def _campaign_runs(self, name: str) -> pd.DataFrame:
        from rcsim.analysis.apps.refinement.evaluate import runs_from_campaign

        # Only what the scoring reads: all ~110 columns of 26,000 runs were ~55 MB a table.
        runs = pd.read_parquet(
            self.paths[name] / campaign_results.RUNS,
            columns=["run_id", "case_index", *SCORED_COLUMNS],
        )
        return runs_from_campaign(runs, self.cases, self.settings.runs_per_case)

    def campaign_before(self) -> dict:
        return self._campaign("campaign_before", self.table_file, self.settings.seed)

    def drivers(self) -> dict:
        from rcsim.analysis.results.drivers.findings import findings, summary_text
        from rcsim.analysis.results.drivers.inputs import load_runs
        from rcsim.analysis.results.drivers.outputs import write_analysis
        from rcsim.analysis.results.drivers.pipeline import Settings, analyze

        s = self.settings
        res = analyze(
            # A campaign of more than 250,000 runs: the analysis' own seed draws the subsample.
            load_runs(self.paths["campaign_before"], seed=s.seed),
            Settings(n_permutations=s.permutations, random_state=s.seed),
        )
        write_analysis(res, self.paths["drivers"], overwrite=True)
        # Every flag of the analysis, or how many more (drivers/findings.csv lists them all).
        return {"findings": summary_text(findings(res), res.settings.alpha)}

    def refine(self) -> dict:
        from rcsim.analysis.apps.refinement.outputs import save_search
        from rcsim.analysis.apps.refinement.parameters import confirmation_seed
        from rcsim.analysis.apps.refinement.search import refine

        s = self.settings
        # The search's baseline is the "before" campaign itself: same seed, same runs.
        spec = refinement_spec(
            runs_per_case=s.runs_per_case,
            seed=s.seed,
            duration_s=s.duration_s,
            vehicle=self.vehicle,
            table=refinement_vehicle(self.table, self.vehicle)[1],
        )
        result = refine(
            spec,
            self.table,
            max_iterations=s.max_iterations,
            progress=self.progress,
            search_runs_per_case=s.search_runs_per_case,
            baseline_runs=self._campaign_runs("campaign_before"),
            # A loop stopped in this stage resumes at its last finished round.
            checkpoint=self.out / ".refine-state",
            # The second gate: a changed row is kept only if it holds on this seed too (the
            # held-out seed stays unused by any decision).
            confirm_seed=confirmation_seed(s.seed, s.held_out_seed),
            max_propellant_rise=s.max_propellant_rise_pct / 100.0,
            plugin=self.plugin,
        )
        save_search(result, self.paths["search"])
        result.table.to_csv(self.paths["refined"])
        changed = (result.table.firing_time_s != self.table.firing_time_s).any(axis=1)
        return {
            "cases_changed": int(changed.sum()),
            "runs_flown": result.runs_flown,
            "search_seed": s.seed,
            "confirm_seed": confirmation_seed(s.seed, s.held_out_seed),
        }

    def campaign_after(self) -> dict:
        return self._campaign(
            "campaign_after", str(self.paths["refined"]), self.settings.held_out_seed
        )

    def check(self) -> dict:
        from rcsim.analysis.apps.refinement.outputs import (
            held_out_check,
            load_search,
            write_refinement,
        )

        s = self.settings
        # The refined table's runs on the fresh seed are the "after" campaign's; the old table
        # is flown on that seed as a campaign too: resumable chunk by chunk, so a loop stopped
        # in this stage goes on where it was.  Its plots are the report's "before" figure
        # beside campaign_after's "after": the same runs.
        self._campaign("campaign_check", self.table_file, s.held_out_seed)
        refined = load_lookup_table(self.paths["refined"])
        ref = held_out_check(
            self.table,
            load_search(self.paths["search"], refined),
            seed=s.seed,
            fresh_seed=s.held_out_seed,
            runs_per_case=s.runs_per_case,
            duration_s=s.duration_s,
            fresh_after_runs=self._campaign_runs("campaign_after"),
            fresh_before_runs=self._campaign_runs("campaign_check"),
            progress=self.progress,
            vehicle=self.vehicle,
            table_file=refinement_vehicle(self.table, self.vehicle)[1],
            max_propellant_rise=s.max_propellant_rise_pct / 100.0,
            drop_regressions=s.drop_regressions,
            # The further seed is one past every seed the loop used (this one included).
            confirm_seed=s.confirm_seed,
            plugin=self.plugin,
        )
        write_refinement(ref, self.paths["refined"], overwrite=True, writer=COMMAND)
        log = ref.changelog
        from rcsim.analysis.apps.loop.report import fresh_seed_change

        # The same fresh seed flown with the table before and after refinement: one contrast.
        info: dict = {
            "held_out_seed": s.held_out_seed,
            "failed_fresh": fresh_seed_change(log),
            "regressions": ref.regressions or "none",
        }
        if ref.further is not None:
            f = ref.further
            info["further_seed"] = f["seed"]
            info["dropped_rows"] = f["dropped_rows"]
            info["failed_further"] = (
                f"{f['failed_before']:,} of {f['runs']:,} runs failed with the original "
                f"table, {f['failed_after']:,} with the final table"
            )
            info["regressions_further"] = f["regressions"] or "none"
        return info

    def rare(self) -> dict:
        return rare_stage(self.out, self.settings, self.progress)

    def report(self) -> dict:
        from rcsim.analysis.apps.loop.report import write_loop_report

        return {"path": str(write_loop_report(self.out, self.settings, self.state.data))}
