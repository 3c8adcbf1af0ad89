"""Campaign specs: a TOML file, validated key by key into a :class:`CampaignSpec`.

Every mistake is an :class:`~rcsim.models.errors.InputError` naming the file, the key path (e.g.
``dispersions.three_sigma.thrust_n``) and the value, raised before anything is written.
Values of the right type but outside the range the physics (or the paper) gives are refused
too, with the range and its reason (:mod:`~rcsim.analysis.engine.campaign.limits`): a 3-sigma
dispersion at least as large as its nominal value, inertia 3-sigma values that can make the
dispersed tensor no rigid body's, a hold disturbance beyond the jets' torque, an
initial rate beyond
the rates the physics step was validated for, a run too long for one chunk's memory.
Units are in the key names (``_deg``, ``_deg_s``, ``_n``, ...); inside, everything is SI.

The commented example (``example_spec.toml`` beside this module, :data:`EXAMPLE_SPEC`,
``rcsim campaign example``) documents every key; the generic reader lives in
:mod:`~rcsim.analysis.engine.campaign.reader`, the sensor / timing / fault tables in
:mod:`~rcsim.analysis.engine.campaign.effects`, the physical ranges in
:mod:`~rcsim.analysis.engine.campaign.limits`, the failure gate in
:mod:`~rcsim.analysis.engine.campaign.gate`.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import os
import tomllib
from dataclasses import dataclass
from importlib.resources import files
from pathlib import Path

import numpy as np

from rcsim.analysis.engine.campaign.effects import TABLES as EFFECT_TABLES
from rcsim.analysis.engine.campaign.effects import Effects, parse_effects
from rcsim.analysis.engine.campaign.gate import check_max_failed_pct, max_failed_pct_problem
from rcsim.analysis.engine.campaign.limits import (
    MAX_INITIAL_RATE_DEG_S,
    check_three_sigma,
    max_duration_s,
    vehicle_limits,
)
from rcsim.analysis.engine.campaign.motion import BUDGET_KEYS
from rcsim.analysis.engine.campaign.reader import Reader, file_digest, file_key
from rcsim.analysis.engine.campaign.spec_vehicle import (
    check_channel_table,
    check_jet_map,
    check_reachable,
    spec_vehicle,
)
from rcsim.analysis.engine.flight import Scenario
from rcsim.lookup.registry import TABLE_CONTROLLERS, controller_names, is_plugin
from rcsim.models.errors import InputError
from rcsim.models.tables import PAPER_LOOKUP_TABLES
from rcsim.spacecraft.dispersions import MAX_SEED, DispersionSigmas
from rcsim.spacecraft.dispersions import THREE_SIGMA_KEYS as _SIGMA_KEYS
from rcsim.spacecraft.vehicle import Vehicle
from rcsim.spacecraft.vehicle.definition import PAPER_RATE_ERROR_DEG_S

#: The commented example spec ``rcsim campaign example`` prints: every key, its default and
#: what it means (a data file beside this module, ``example_spec.toml``; a test loads it).
EXAMPLE_SPEC = (files("rcsim.analysis.engine.campaign") / "example_spec.toml").read_text(
    encoding="utf-8"
)

#: The failure threshold of a spec without ``[failure] rate_error_deg_s`` whose vehicle file
#: gives none either [deg/s] (Gambone sec. III; example_spec.toml says why).
DEFAULT_RATE_ERROR_DEG_S = PAPER_RATE_ERROR_DEG_S
#: :func:`failure_source` of a spec whose ``[failure]`` gives its thresholds itself.
SPEC_FAILURE_SOURCE = "rate threshold from the spec's [failure]"
HISTORY_MODES = ("none", "failures", "all", "first")
SCENARIO_KINDS = ("rate-cases", "maneuver", "hold")


@dataclass(frozen=True)
class CampaignSpec:
    """A validated campaign (SI inside).

    Attributes
    ----------
    source : str
        Where it was read from (for messages).
    seed, runs_per_case, chunk_size : int
    cases : tuple of rcsim.analysis.engine.flight.Scenario
        Case ``c`` holds runs ``c * runs_per_case ... (c + 1) * runs_per_case - 1``.
    controller : str
        A built-in controller, a registered plug-in's name or ``plugin:package.module:factory``
        (:mod:`rcsim.lookup.plugins`).
    table : str or None
        Absolute path of the lookup table (None: packaged default / phase-plane).
    sigmas : DispersionSigmas
        One-sigma dispersions after overrides and scale.
    rate_threshold_rad_s : float
    attitude_threshold_rad : float or None
    histories : str
    first_k : int
    plots : bool
    resolved : dict
        The spec with defaults filled in and paths made absolute (JSON-able); what the
        manifest records, what ``--resume`` compares and what ``replay`` rebuilds from.
    vehicle : rcsim.spacecraft.vehicle.Vehicle
        The vehicle flown, resolved once when the spec is read (the ``vehicle`` key, or the
        paper's; with the spec's ``[control]`` overrides of its profile): its model, jets,
        profile, valve limits, timing and tank.  It pickles small (its model is compiled once
        per process, cached by SHA-256), so a spec travels to workers as it is.  In
        ``resolved``: its file and SHA-256 when the spec names one, and ``[control]`` when the
        spec gives it (other specs resolve as before).
    effects : Effects
        Sensors, valve timing and jet faults (:mod:`~rcsim.analysis.engine.campaign.effects`);
        each ``is_none()`` when the spec has no such table.
    controller_params : dict
        A plug-in's ``[controller.params]`` (empty for a built-in).
    max_failed_pct : float or None
        The failure gate, percent of runs (:mod:`~rcsim.analysis.engine.campaign.gate`);
        None: no gate.
        Not in ``resolved``: it judges results and changes nothing that is flown, so a
        campaign can be resumed under another limit.
    failure_source : str
        Where the failure thresholds came from (:func:`failure_source`): the spec's
        ``[failure]``, the vehicle file's, or the paper's (said plainly when they judge another
        vehicle); the manifest's ``thresholds.source``, the summary line and the report say it.
    """

    source: str
    seed: int
    runs_per_case: int
    chunk_size: int
    cases: tuple
    controller: str
    table: str | None
    sigmas: DispersionSigmas
    rate_threshold_rad_s: float
    attitude_threshold_rad: float | None
    histories: str
    first_k: int
    plots: bool
    resolved: dict
    vehicle: Vehicle
    max_failed_pct: float | None = None
    effects: Effects = Effects()
    failure_source: str = ""
    controller_params: dict = dataclasses.field(default_factory=dict)

    def make_controller(self, **options):
        """The campaign's controller, built for its vehicle (a plug-in with its
        ``[controller.params]``): what every chunk, replay and rare-event flight flies."""
        from rcsim.lookup.registry import make_controller

        if self.controller_params:
            options["plugin_params"] = self.controller_params
        return make_controller(self.controller, self.vehicle, table=self.table, **options)

    @property
    def sensor(self):
        """:class:`rcsim.spacecraft.effect_draws.SensorSpec` of the campaign."""
        return self.effects.sensor

    @property
    def timing(self):
        """:class:`rcsim.spacecraft.effect_draws.TimingSpec` of the campaign."""
        return self.effects.timing

    @property
    def fault(self):
        """:class:`rcsim.spacecraft.effect_draws.FaultSpec` of the campaign."""
        return self.effects.fault

    @property
    def n_cases(self) -> int:
        return len(self.cases)

    @property
    def n_jets(self) -> int:
        """The flown vehicle's jet count: the width of every per-jet draw, record and column
        of the campaign."""
        return self.vehicle.definition.n_jets

    @property
    def cycle_s(self) -> float:
        """The control cycle the campaign flies [s]: the vehicle profile's, which every
        controller and valve model it builds takes, so its plans (chunk sizes, delay limits,
        disk estimates) use it before any flight; each flight's
        :class:`rcsim.spacecraft.history.History` then carries the cycle it flew."""
        return self.vehicle.control.cycle_s

    @property
    def n_runs(self) -> int:
        return self.n_cases * self.runs_per_case

    def case_of(self, run_id: int) -> int:
        """Case index of a run (run ids are case-major)."""
        return int(run_id) // self.runs_per_case

    def digest(self) -> str:
        """SHA-256 of the resolved spec: equal digests fly equal runs."""
        return hashlib.sha256(json.dumps(self.resolved, sort_keys=True).encode()).hexdigest()

    def with_runs_per_case(self, n: int) -> CampaignSpec:
        """The same campaign with ``n`` runs per case (what the CLI's ``--runs-per-case`` sets)."""
        resolved = dict(self.resolved, runs_per_case=n)
        spec = parse_dict(resolved, source=f"{self.source} with runs_per_case={n}", base_dir=None)
        # resolved states every threshold: where they came from is this spec's
        return dataclasses.replace(
            spec, max_failed_pct=self.max_failed_pct, failure_source=self.failure_source
        )

    def with_max_failed_pct(self, pct) -> CampaignSpec:
        """The same campaign under the failure gate ``pct`` (overrides the spec's).

        Raises
        ------
        InputError
            About parameter ``max_failed_pct``: not a number in [0, 100].
        """
        return dataclasses.replace(self, max_failed_pct=check_max_failed_pct(pct))


# ----------------------------------------------------------------------------------------------
# Reading (the key-by-key reader is rcsim.analysis.engine.campaign.reader)
# ----------------------------------------------------------------------------------------------
def _scenarios(raw, source: str, resolved: list, vehicle: Vehicle) -> list[Scenario]:
    """``[scenario]`` (or ``[[scenario]]``): the cases, for ``vehicle`` (its jet count and
    cycle size a run's per-cycle record, hence the longest run; its jets' torque bounds a
    hold's disturbance)."""
    from rcsim.models.tables import load_rate_cases

    n_jets, cycle_s = vehicle.definition.n_jets, vehicle.control.cycle_s
    blocks = raw if isinstance(raw, list) else [raw]
    if not blocks:
        raise InputError(f"{source}: scenario: the list is empty")
    cases: list[Scenario] = []
    for b, block in enumerate(blocks):
        r = Reader(block, "scenario" if not isinstance(raw, list) else f"scenario[{b}]", source)
        kind = r.choice("kind", "rate-cases", SCENARIO_KINDS)
        duration = r.number("duration_s", 20.0, minimum=0.0, strict=True)
        longest = max_duration_s(n_jets=n_jets, cycle_s=cycle_s, n_modes=vehicle.model.njnt - 1)
        if duration > longest:
            raise r.error(
                "duration_s",
                f"must be <= {longest:.0f} s: one run's "
                "per-cycle record must fit a chunk's memory budget (analysis."
                "engine.campaign.limits.HISTORY_BUDGET_BYTES)",
                duration,
            )
        out = {"kind": kind, "duration_s": duration}
        if kind == "rate-cases":
            table = load_rate_cases()
            numbers = r.raw("cases", "all")
            if numbers == "all":
                numbers = [int(c) for c in table.case]
            elif (
                not isinstance(numbers, list)
                or not numbers
                or not all(isinstance(c, int) and not isinstance(c, bool) for c in numbers)
            ):
                raise r.error("cases", 'must be "all" or a non-empty list of case numbers', numbers)
            bad = [c for c in numbers if c not in set(int(c) for c in table.case)]
            if bad:
                raise r.error(
                    "cases", f"no such rate case {bad[0]}; cases are 1..{len(table.case)}", numbers
                )
            mode = r.choice("mode", "command", ("command", "damp"))
            for c in numbers:
                rate = table.rate_cmd[list(table.case).index(c)]
                if mode == "command":
                    cases.append(
                        Scenario(
                            name=f"rate-{c:02d}", duration_s=duration, rate_cmd_rad_s=np.array(rate)
                        )
                    )
                else:
                    cases.append(
                        Scenario(
                            name=f"damp-{c:02d}", duration_s=duration, omega0_rad_s=np.array(rate)
                        )
                    )
            out.update(cases=list(numbers), mode=mode)
        else:
            name = r.raw("name", kind)
            if not isinstance(name, str) or not name.replace("-", "").replace("_", "").isalnum():
                raise r.error("name", "must be a name of letters, digits, '-' or '_'", name)
            if kind == "maneuver":
                att = r.vector3("attitude_deg", None)
                if np.linalg.norm(att) >= 180.0:
                    raise r.error("attitude_deg", "rotation must be under 180 deg", att)
                cases.append(Scenario(name=name, duration_s=duration, att_cmd_rad=np.radians(att)))
                out.update(name=name, attitude_deg=att)
            else:
                dist = r.vector3("disturbance_n_m", [0.0, 0.0, 0.0])
                limits = vehicle_limits(vehicle)
                problem = vehicle.disturbance_problem(dist)
                if problem:
                    raise r.error("disturbance_n_m", problem, dist)
                w0 = r.vector3("initial_rate_deg_s", [0.0, 0.0, 0.0])
                if np.linalg.norm(w0) > limits["initial_rate_deg_s"]:
                    raise r.error(
                        "initial_rate_deg_s",
                        f"magnitude must be <= {limits['initial_rate_deg_s']:.4g} deg/s, the "
                        f"largest rate {vehicle.ref}'s "
                        f"{vehicle.definition.timestep_s * 1e3:g} ms physics step is validated "
                        f"for ({MAX_INITIAL_RATE_DEG_S:g} deg/s at 40 ms, docs/convergence.md: "
                        "the same rotation per step)",
                        w0,
                    )
                cases.append(
                    Scenario(
                        name=name,
                        duration_s=duration,
                        omega0_rad_s=np.radians(w0),
                        disturbance_n_m=np.array(dist),
                    )
                )
                out.update(name=name, disturbance_n_m=dist, initial_rate_deg_s=w0)
        r.done()
        resolved.append(out)
    names = [c.name for c in cases]
    dup = next((n for n in names if names.count(n) > 1), None)
    if dup is not None:
        raise InputError(f"{source}: scenario: case name {dup!r} appears twice; give each a name")
    return cases


def parse_dict(
    data: dict, *, source: str = "<dict>", base_dir: str | os.PathLike | None = None
) -> CampaignSpec:
    """Validate a spec already read into a dict (from TOML, a manifest's ``resolved``, or code).

    Parameters
    ----------
    data : dict
        The spec's tables and keys, as the TOML file has them (``rcsim campaign example``).
    source : str
        Shown in error messages (the file name); default ``"<dict>"``.
    base_dir : path, optional
        Relative file paths (tables) are relative to it; default the working directory.

    Raises
    ------
    InputError
        Naming ``source``, the key path and the value.
    """
    base_dir = Path.cwd() if base_dir is None else Path(base_dir)
    top = Reader(data, "", source)
    seed = top.integer("seed", 1, minimum=0, maximum=MAX_SEED)  # stored as int64
    runs = top.integer("runs_per_case", 100, minimum=1)
    chunk = top.integer("chunk_size", 512, minimum=1)
    # A run is a function of (seed, run id); run ids are case * runs_per_case + k.
    resolved: dict = {"seed": seed, "runs_per_case": runs, "chunk_size": chunk}
    if not top.has("scenario"):
        raise InputError(f"{source}: scenario: missing; see `rcsim campaign example`")
    raw_scen = top.raw("scenario")
    # The vehicle first: its jet count sizes every per-jet record (the longest run, the
    # jets a fault may name), its profile's cycle every plan, its jets' torque the limits.
    vehicle, vehicle_resolved, named = spec_vehicle(top, base_dir, source)
    scen_resolved: list = []
    cases = _scenarios(raw_scen, source, scen_resolved, vehicle)
    resolved["scenario"] = scen_resolved if isinstance(raw_scen, list) else scen_resolved[0]
    # Recorded only when given: other specs resolve as before.
    resolved.update(vehicle_resolved)
    if named:
        check_reachable(vehicle, cases, source)
    name, table, resolved["controller"] = _controller(
        top.table_("controller"), base_dir, vehicle.control.cycle_s
    )
    check_jet_map(vehicle, name, table, source)
    if is_plugin(name):
        check_plugin(resolved["controller"], vehicle, source)
    if table is not None and table not in PAPER_LOOKUP_TABLES:
        check_channel_table(name, table, vehicle, source)
    sigmas, effects, resolved["dispersions"] = _dispersions(
        top.table_("dispersions"), base_dir, cases, source, vehicle, named
    )
    rate_thr, att_thr, max_failed, resolved["failure"], failure_from = _failure(
        top.table_("failure"), vehicle
    )
    histories, first_k, plots, resolved["output"] = _output(top.table_("output"))
    top.done()
    return CampaignSpec(
        source=source,
        seed=seed,
        runs_per_case=runs,
        chunk_size=chunk,
        cases=tuple(cases),
        controller=name,
        table=table,
        controller_params=resolved["controller"].get("params", {}),
        sigmas=sigmas,
        rate_threshold_rad_s=math.radians(rate_thr),
        attitude_threshold_rad=None if att_thr is None else math.radians(att_thr),
        histories=histories,
        first_k=first_k,
        plots=plots,
        resolved=resolved,
        vehicle=vehicle,
        max_failed_pct=max_failed,
        effects=effects,
        failure_source=failure_from,
    )


def _controller(c: Reader, base_dir: Path, cycle_s: float) -> tuple[str, str | None, dict]:
    """``[controller]``: name, table (absolute path, paper table name or None; a table file
    in whole cycles of the vehicle's ``cycle_s``), resolved."""
    from rcsim.lookup.jet_sets import load_table_for_jets
    from rcsim.models.tables import load_lookup_table

    name = _controller_name(c, base_dir)
    table = file_key(c, "table", base_dir, names=tuple(PAPER_LOOKUP_TABLES))
    if name not in TABLE_CONTROLLERS and table is not None:
        raise c.error("table", "is only for the lookup and adaptive controllers", table)
    jets_off: tuple = ()
    if table in PAPER_LOOKUP_TABLES:
        load_lookup_table(table)  # InputError naming the file, row and column
    elif table is not None:
        # Checked against the jets of the vehicle it was made for (its companion file).
        jets_off = load_table_for_jets(table, cycle_s=cycle_s)[1]
    c.unlisted.add("jets_off")  # a manifest's record, not a key to offer a user
    if c.has("jets_off"):  # a manifest's: the companion must still name the same jets
        expect = c.raw("jets_off")
        if expect != list(jets_off):
            raise c.error(
                "table",
                f"companion file now names jets off {list(jets_off)}, "
                f"the campaign flew it for {expect}",
                table,
            )
    if c.has("table_sha256"):  # present in a manifest's resolved spec (replay, resume)
        expect = c.raw("table_sha256")
        if expect != file_digest(table):
            what = "packaged paper table" if table in PAPER_LOOKUP_TABLES else "file"
            raise c.error("table", f"{what} changed since the campaign ran (sha256 differs)", table)
    recipe = _recipe_file(table)
    recipe_sha = None if recipe is None else file_digest(str(recipe))
    if c.has("recipe_sha256") and c.raw("recipe_sha256") != recipe_sha:
        problem = (
            "is no longer the channel table the campaign flew"
            if recipe is None
            else f"recipe {recipe.name} changed since the campaign ran (sha256 differs)"
        )
        raise c.error("table", problem, table)
    params = c.raw("params", {})
    if not isinstance(params, dict):
        raise c.error("params", "must be a table of the plug-in's parameters", params)
    if params and not is_plugin(name):
        raise c.error("params", f"are only for a plug-in controller, not {name!r}", params)
    c.unlisted.add("plugin_record")  # a manifest's record of the plug-in that flew
    record = c.raw("plugin_record")
    c.done()
    resolved: dict = {
        "name": name,
        "table": table or "default",
        "table_sha256": file_digest(table),
    }
    if is_plugin(name):  # recorded only for a plug-in: other specs resolve as before
        resolved["params"] = params
        if record is not None:
            resolved["plugin_record"] = record
    if jets_off:  # recorded only when there are some: other specs resolve as before
        resolved["jets_off"] = list(jets_off)
    if recipe_sha is not None:  # a channel table's recipe is part of the table
        resolved["recipe_sha256"] = recipe_sha
    return name, table, resolved


def _absolute_plugin_file(target: str, base_dir: Path) -> str:
    """``path/to/fsw.py:factory`` with the file made absolute (relative to the spec's
    directory), so a resume or replay from elsewhere imports the same file."""
    module, _, attr = target.rpartition(":")
    if not module.endswith(".py"):
        return target
    path = Path(module).expanduser()
    return f"{path if path.is_absolute() else (base_dir / path).resolve()}:{attr}"


def _controller_name(c: Reader, base_dir: Path) -> str:
    """``[controller]``'s ``name`` (a built-in, a registered plug-in's name,
    ``plugin:package.module:factory`` or ``library:path``), ``plugin = "package.module:factory"``
    (the same plug-in by its import path; or ``"path/to/fsw.py:factory"``) or ``library =
    "path/to/libfsw.so"`` (C flight code, :mod:`rcsim.lookup.c_library`); a path is relative
    to the spec."""
    from rcsim.lookup.c_library import LIBRARY_PREFIX
    from rcsim.lookup.plugins import PLUGIN_PREFIX

    named = c.has("name")  # asked first: the order unknown-key messages list the keys in
    library = c.raw("library")
    if library is not None:
        if named or c.has("plugin"):
            raise c.error("library", "names the controller: give one of name, plugin, library")
        if not isinstance(library, str) or not library:
            raise c.error("library", "must be the path of a shared library", library)
        path = Path(library).expanduser()
        return LIBRARY_PREFIX + str(path if path.is_absolute() else (base_dir / path).resolve())
    plugin = c.raw("plugin")
    if plugin is not None:
        if named:
            raise c.error("plugin", "names the controller: give plugin or name, not both", plugin)
        if not isinstance(plugin, str) or plugin.count(":") != 1:
            raise c.error(
                "plugin", "must be 'package.module:factory' or 'path/to/file.py:factory'", plugin
            )
        return PLUGIN_PREFIX + _absolute_plugin_file(plugin, base_dir)
    name = c.raw("name")
    choices = controller_names()
    if name is None:
        raise c.error("name", f"is required; one of {', '.join(choices)} (or plugin = ...)")
    if not isinstance(name, str) or not (name in choices or is_plugin(name)):
        raise c.error(
            "name",
            f'must be one of {", ".join(choices)}, or a plug-in: plugin = "package.module:factory"',
            name,
        )
    return name


def check_plugin(spec_resolved: dict, vehicle: Vehicle, source: str) -> None:
    """Build a plug-in controller once on ``vehicle`` (its import, factory and one probe
    cycle: :func:`rcsim.lookup.plugins.build`) and record what it was in
    ``spec_resolved["plugin_record"]``; refuse (one line naming ``source``) a plug-in whose
    source changed since a manifest recorded it."""
    from rcsim.lookup.plugins import build

    name = spec_resolved["name"]
    try:
        info = build(name, vehicle, spec_resolved.get("params")).info.record()
    except InputError as exc:
        raise InputError(f"{source}: controller: {exc}") from None
    old = spec_resolved.get("plugin_record")
    if old is not None and old.get("source_sha256") != info["source_sha256"]:
        raise InputError(
            f"{source}: controller: plug-in {old.get('target')!r} changed since the campaign "
            f"ran (its source's sha256 differs: {old.get('source_sha256')} -> "
            f"{info['source_sha256']})"
        )
    spec_resolved["plugin_record"] = info


def _recipe_file(table: str | None) -> Path | None:
    """A channel table's recipe file, None for any other table."""
    from rcsim.models.tables import is_channel_table, recipe_path

    if table is None or table in PAPER_LOOKUP_TABLES or not is_channel_table(table):
        return None
    return recipe_path(table)


def _dispersions(
    d: Reader,
    base_dir: Path,
    cases: list[Scenario],
    source: str,
    vehicle: Vehicle,
    named: bool,
) -> tuple[DispersionSigmas, Effects, dict]:
    """``[dispersions]``: Table 5 (file, scale, 3-sigma overrides, converted to SI one-sigmas
    here, each bounded by ``vehicle``'s ranges) and the sensor / timing / fault tables (a
    fault's jets among the vehicle's).  With a vehicle the spec ``named`` and ``table =
    "default"``, the table is the vehicle file's ``[dispersions]`` (a row it leaves out is not
    dispersed); without, Table 5."""
    from rcsim.models.tables import load_dispersions

    n_jets = vehicle.definition.n_jets
    disp_table = file_key(d, "table", base_dir)
    frame = load_dispersions(disp_table)
    limits = vehicle_limits(vehicle)
    definition = vehicle.definition if named else None
    if named:
        if disp_table is None:
            own = vehicle.definition.three_sigma
            frame["three_sigma"] = [float(own.get(name, 0.0)) for name in frame["name"]]
            for name in own:  # rows beyond Table 5 (CG y and z, products of inertia)
                if name not in set(frame["name"]):
                    frame.loc[len(frame), ["name", "three_sigma"]] = [name, float(own[name])]
    if d.has("table_sha256"):
        if d.raw("table_sha256") != file_digest(disp_table):
            raise d.error(
                "table", "file changed since the campaign ran (sha256 differs)", disp_table
            )
    scale = d.number("scale", 1.0, minimum=0.0)
    over = d.table_("three_sigma")
    overrides = {}
    for key, (row, factor) in _SIGMA_KEYS.items():
        if over.has(key):
            overrides[key] = over.number(key, None, minimum=0.0)
            if row in set(frame["name"]):
                frame.loc[frame["name"] == row, "three_sigma"] = overrides[key] * factor
            else:
                frame.loc[len(frame), ["name", "three_sigma"]] = [row, overrides[key] * factor]
    over.done()
    check_three_sigma(frame, scale, overrides, source, _SIGMA_KEYS, limits)
    d.takes(*EFFECT_TABLES)  # read from d.table by parse_effects
    effects, effects_resolved = parse_effects(
        d.table,
        source=source,
        cycle_s=vehicle.control.cycle_s,
        longest_s=max(case.duration_s for case in cases),
        n_jets=n_jets,
        vehicle=f"vehicle {vehicle.ref}" if named else "the paper's vehicle",
        definition=definition,
    )
    d.done()
    records = effects.records()
    longest = max_duration_s(
        **records, n_jets=n_jets, cycle_s=vehicle.control.cycle_s, n_modes=vehicle.model.njnt - 1
    )
    if any(records.values()) and any(case.duration_s > longest for case in cases):
        what = [f"[dispersions.{'/'.join(effects.groups)}]"] if effects.groups else []
        what += ["the vehicle's valve timing"] if effects.vehicle_timing is not None else []
        raise InputError(
            f"{source}: scenario.duration_s: must be <= {longest:.0f} s with "
            f"{' and '.join(what)} (their per-cycle records "
            "must fit a chunk's memory budget too)"
        )
    try:
        sigmas = DispersionSigmas.from_table(frame, scale)
    except InputError as exc:
        raise InputError(f"{source}: dispersions.table: {exc}") from None
    resolved = {
        "table": disp_table or "default",
        "table_sha256": file_digest(disp_table),
        "scale": scale,
        "three_sigma": overrides,
        **effects_resolved,
    }
    return sigmas, effects, resolved


def _failure(f: Reader, vehicle: Vehicle) -> tuple[float, float | None, float | None, dict, str]:
    """``[failure]``: rate and attitude thresholds [deg/s, deg], the gate [%], resolved, and
    where the thresholds came from (:func:`failure_source`).  A key the spec leaves out is the
    vehicle file's ``[failure]`` one, else the paper's (rate: 0.04 deg/s; attitude: none)."""
    own = vehicle.definition.failure
    spec_rate, spec_att = f.has("rate_error_deg_s"), f.has("attitude_error_deg")
    rate_thr = f.number(
        "rate_error_deg_s",
        own.get("rate_error_deg_s", DEFAULT_RATE_ERROR_DEG_S),
        minimum=0.0,
        strict=True,
    )
    att_thr = (
        f.number("attitude_error_deg", None, minimum=0.0, strict=True)
        if spec_att
        else own.get("attitude_error_deg")
    )
    # Budgets on the run's propellant and translation: set only when given, so a
    # spec without them resolves (and resumes) as before.
    budgets = {k: f.number(k, None, minimum=0.0, strict=True) for k in BUDGET_KEYS if f.has(k)}
    max_failed = f.raw("max_failed_pct") if f.has("max_failed_pct") else None
    if max_failed is not None:
        problem = max_failed_pct_problem(max_failed)
        if problem is not None:
            raise f.error("max_failed_pct", problem, max_failed)
        max_failed = float(max_failed)
    f.done()
    resolved: dict = {"rate_error_deg_s": rate_thr}
    if att_thr is not None:
        resolved["attitude_error_deg"] = att_thr
    resolved.update(budgets)
    return rate_thr, att_thr, max_failed, resolved, failure_source(vehicle, spec_rate, spec_att)


def failure_source(vehicle: Vehicle, spec_rate: bool, spec_att: bool) -> str:
    """Where a campaign's failure thresholds came from, in words: the spec's ``[failure]``,
    the vehicle file's, or the paper's -- said plainly when the paper's judge another vehicle
    (0.04 deg/s was set for the paper's 3.5 t vehicle, Gambone sec. III).

    Parameters
    ----------
    spec_rate, spec_att : bool
        The spec's ``[failure]`` gives ``rate_error_deg_s`` / ``attitude_error_deg``.
    """
    own = vehicle.definition.failure
    if spec_rate:
        rate = "the spec's [failure]"
        if spec_att or "attitude_error_deg" not in own:
            return SPEC_FAILURE_SOURCE
    elif "rate_error_deg_s" in own:
        rate = f"{vehicle.label}'s own [failure]"
    elif vehicle.ref == "paper":
        rate = "the paper's (Gambone sec. III)"
    else:
        rate = (
            f"the paper's {DEFAULT_RATE_ERROR_DEG_S:g} deg/s (Gambone sec. III, set for the "
            f"paper's vehicle) applied to {vehicle.name}: neither the spec nor the vehicle file "
            "gives [failure] rate_error_deg_s"
        )
    text = f"rate threshold from {rate}"
    if not spec_att and "attitude_error_deg" in own:
        text += f"; attitude threshold from {vehicle.label}'s own [failure]"
    return text


def failure_note(spec: CampaignSpec) -> str:
    """:attr:`CampaignSpec.failure_source` when a reader could not guess it -- the paper's
    thresholds judging another vehicle, or a vehicle file's own -- else '' (the spec's own
    ``[failure]``, the paper's on the paper's vehicle): what a summary line adds."""
    plain = spec.vehicle.ref == "paper" or spec.failure_source == SPEC_FAILURE_SOURCE
    return "" if plain else spec.failure_source


def _output(o: Reader) -> tuple[str, int, bool, dict]:
    """``[output]``: histories kept, first K, plots, resolved."""
    histories = o.choice("histories", "failures", HISTORY_MODES)
    first_k = o.integer("first_k", 5, minimum=0)
    plots = o.raw("plots", True)
    if not isinstance(plots, bool):
        raise o.error("plots", "must be true or false", plots)
    o.done()
    return histories, first_k, plots, {"histories": histories, "first_k": first_k, "plots": plots}


def load_spec(path: str | os.PathLike) -> CampaignSpec:
    """Read and validate a campaign spec file.

    Raises
    ------
    InputError
        Unreadable file, TOML syntax error, unknown key, bad value, missing table file.
    """
    path = Path(path)
    try:
        # utf-8-sig: a byte-order mark (what some Windows editors save) is not TOML syntax.
        text = path.read_text(encoding="utf-8-sig")
    except OSError as exc:
        raise InputError(f"{path}: cannot read campaign spec: {exc.strerror}") from None
    except UnicodeDecodeError as exc:
        raise InputError(
            f"{path}: not a UTF-8 text file (byte {exc.start}); a campaign spec is TOML"
        ) from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{path}: not valid TOML: {exc}") from None
    return parse_dict(data, source=str(path), base_dir=path.absolute().parent)
