"""The flight-software profile: a vehicle file's ``[control]`` section, as data.

Every tuning value a controller, the flight loop or table generation uses is here, once, with
its unit in its key (degrees and deg/s in files, SI inside): the control cycle, the maneuver
rate, the maneuver attitude limit and the no-firing band around it, the rate and attitude
deadbands, the hold time, the on-time limit, what a pulse shorter than the jets' minimum
on-time becomes (the minimum pulse policy), and the total rate of the 26 rate cases a lookup
table is generated for.  Basilisk takes these as module parameters; rcsim takes them from the
vehicle flown, so a practitioner retunes a vehicle in its file, per campaign spec
(``[control]``) or on the command line (``--control KEY=VALUE``), and a manifest or report names
the profile that flew (:meth:`ControlProfile.record`).

The paper's values are ``paper.toml``'s ``[control]`` (Gambone sec. II and Table 4, the
phase-plane and allocator deadbands rcsim's controllers always used), and a vehicle file that
leaves a key out takes the paper's value for it; :attr:`ControlProfile.source` says which keys
came from where.

========================================  ======================================  ============
key (``[control]``)                       what                                    paper
========================================  ======================================  ============
``cycle_s``                               control cycle (flight loop, every       0.04 s
                                          controller, valve limits)
``maneuver_rate_deg_s``                   total maneuver rate (every controller)  0.2 deg/s
``maneuver_limit_deg``                    total attitude error above which the    0.6 deg
                                          maneuver rate is flown (lookup,
                                          allocator)
``maneuver_band_deg``                     half-width of the no-firing band        0.1 deg
                                          around the limit (lookup; Figs 17-18)
``rate_deadband_deg_s``                   per-axis rate-error deadband (lookup:   0.06 deg/s
                                          Table 4's rate error limit)
``on_time_limit_s``                       a jet gets a new firing only below      0.03 s
                                          this remaining on-time (lookup)
``hold_time_s``                           settling wait after a firing (lookup)   0.16 s
``rate_case_deg_s``                       total rate of the 26 rate cases a       0.3 deg/s
                                          lookup table is generated for
``phase_plane.attitude_deadband_deg``     phase plane's attitude deadband         0.25 deg
``phase_plane.rate_deadband_deg_s``       phase plane's rate deadband             0.03 deg/s
``allocator.rate_deadband_deg_s``         allocator: no new plan below this       0.004 deg/s
``allocator.trim_deadband_deg_s``         allocator: no plan that needs a         0.01 deg/s
                                          minimum pulse while every axis's
                                          rate error is below this (no trim
                                          pairs; the rate cases' 0.01 deg/s
                                          coupled-axis requirement)
``maneuver_hysteresis_deg``               a maneuver, once entered above the      0 deg
                                          limit, ends only below limit - this
                                          (lookup, allocator; 0: no hysteresis,
                                          the paper's rule)
``min_pulse``                             a channel table's share shorter than    accumulate
                                          the minimum on-time: ``accumulate``,
                                          ``round-up`` or ``drop``
``allocation``                            what the allocator minimises:           propellant
                                          ``propellant``,
                                          ``propellant+translation`` or
                                          ``translation-first``
========================================  ======================================  ============

Every key has a physical bound, from the profile's other keys, its cycle and the vehicle's
physics step (:func:`bound_problems`, :func:`rate_problems`; listed with their reasons in
``docs/vehicles.md``); a value outside it is refused with the bound and why, naming the key
and where it came from.

Allocation modes (:mod:`rcsim.lookup.allocator`), each honouring the minimum on-time inside
the optimisation (a jet is off or on for at least its minimum pulse):

* ``propellant`` (default): least propellant for the rate change; among plans of equal
  propellant, the one with least translation (a tie-break priced at 10^-6 of the next mode's).
  The default because it is what an allocator is judged by, and what the name says.
* ``propellant+translation``: propellant plus the translation left, priced at the propellant
  that would null it with the same jets, ``m / (Isp g0)`` kg per m/s of ``|dv|_1``.
* ``translation-first``: translation priced 1000 times that: a plan cancels the jets'
  coupled force first (when the layout can), then spends least propellant.

The minimum pulse policy applies to pulses a channel table's recipe *computes* (its per-cycle
jet shares, :class:`rcsim.lookup.channels.ChannelMap`); a jet table's entries are what it
fires, and the allocator honours the minimum on-time inside its optimisation
(:mod:`rcsim.lookup.allocator_controller`).

* ``accumulate``: a short pulse is owed, and fired at the minimum on-time once what is owed
  reaches it (or half of it when the firing ends).  The impulse asked for is delivered, late
  by up to the firing's length.
* ``round-up``: a short pulse fires at the minimum on-time at once (no delay; more
  propellant and a larger rate change than asked for).
* ``drop``: a short pulse is not fired (rate errors smaller than a minimum pulse's stay).

With a minimum on-time of zero (the paper's vehicle) the three are the same.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, fields, replace

from rcsim.models.errors import InputError
from rcsim.models.tables.constants import PAPER_CYCLE_S
from rcsim.models.toml_reader import Reader

#: Longest control cycle a profile may give [s]: an attitude-control loop slower than 1 Hz is
#: no reaction-control loop (a cycle in ms written under an ``_s`` key is over).
MAX_CYCLE_S = 1.0
#: Shortest [s]: 1 ms, 40 times faster than the paper's; below it the valves (ms latencies)
#: could not follow, and the physics would need sub-ms steps.
MIN_CYCLE_S = 1e-3

#: (file key, field, unit factor to SI, rule) in file order; rule: "pos" > 0, "nonneg" >= 0.
#: Sub-table keys are written ``table.key``.
_KEYS: tuple[tuple[str, str, float, str], ...] = (
    ("cycle_s", "cycle_s", 1.0, "pos"),
    ("maneuver_rate_deg_s", "maneuver_rate_rad_s", math.pi / 180, "pos"),
    ("maneuver_limit_deg", "maneuver_limit_rad", math.pi / 180, "pos"),
    ("maneuver_band_deg", "maneuver_band_rad", math.pi / 180, "nonneg"),
    ("rate_deadband_deg_s", "rate_deadband_rad_s", math.pi / 180, "pos"),
    ("on_time_limit_s", "on_time_limit_s", 1.0, "pos"),
    ("hold_time_s", "hold_time_s", 1.0, "nonneg"),
    ("rate_case_deg_s", "rate_case_rad_s", math.pi / 180, "pos"),
    ("phase_plane.attitude_deadband_deg", "phase_plane_att_deadband_rad", math.pi / 180, "pos"),
    ("phase_plane.rate_deadband_deg_s", "phase_plane_rate_deadband_rad_s", math.pi / 180, "pos"),
    ("allocator.rate_deadband_deg_s", "allocator_rate_deadband_rad_s", math.pi / 180, "pos"),
    ("allocator.trim_deadband_deg_s", "allocator_trim_deadband_rad_s", math.pi / 180, "nonneg"),
    ("maneuver_hysteresis_deg", "maneuver_hysteresis_rad", math.pi / 180, "nonneg"),
)
#: Every numeric field of a profile (SI names), in file order.
CONTROL_FIELDS = tuple(name for _, name, _, _ in _KEYS)
#: Field -> file key, unit factor (file unit to SI) and unit, for messages.
_KEY_OF = {name: key for key, name, _, _ in _KEYS}
_FACTOR = {name: factor for _, name, factor, _ in _KEYS}
_UNIT = {
    name: "deg/s" if key.endswith("_deg_s") else "deg" if key.endswith("_deg") else "s"
    for key, name, _, _ in _KEYS
}
#: Largest body rate a profile may ask for at the validated physics step [deg/s]: the
#: convergence study (docs/convergence.md) validates the 40 ms RK4 step with a torque-free
#: tumble at ~3 deg/s, 10 times the paper's largest commanded rate (0.3 deg/s, Table 3);
#: what it validates is the rotation per step (0.12 deg), so another step gets the rate that
#: turns as far per step (:func:`validated_rate_rad_s`).
MAX_VALIDATED_RATE_DEG_S = 3.0
#: The physics step the convergence study validated [s]: the paper's (its control cycle).
VALIDATED_STEP_S = PAPER_CYCLE_S
#: What a pulse shorter than the minimum on-time becomes (module docstring).
MIN_PULSE_POLICIES = ("accumulate", "round-up", "drop")
#: What the allocator minimises (module docstring).
ALLOCATION_MODES = ("propellant", "propellant+translation", "translation-first")
#: Keys whose value is a word, with the words each takes.
_CHOICE_KEYS: dict[str, tuple[str, ...]] = {
    "min_pulse": MIN_PULSE_POLICIES,
    "allocation": ALLOCATION_MODES,
}
#: Every key a ``[control]`` section (or ``--control KEY=VALUE``) takes.
CONTROL_KEYS = tuple(key for key, _, _, _ in _KEYS) + tuple(_CHOICE_KEYS)


@dataclass(frozen=True)
class ControlProfile:
    """A vehicle's flight-software profile, SI (module docstring: keys, meanings, paper values).

    Attributes
    ----------
    cycle_s : float
        Control cycle [s]: the flight loop's and every controller's (one owner).
    maneuver_rate_rad_s, maneuver_limit_rad, maneuver_band_rad : float
        Maneuver rate [rad/s], the total attitude error above which it is flown [rad] and the
        half-width of the no-firing band around that limit [rad].
    rate_deadband_rad_s : float
        The lookup controller's per-axis rate-error deadband [rad/s].
    on_time_limit_s, hold_time_s : float
        The lookup controller's on-time limit and hold time [s].
    rate_case_rad_s : float
        Total rate of the 26 rate cases a lookup table is generated for [rad/s].
    phase_plane_att_deadband_rad, phase_plane_rate_deadband_rad_s : float
        The phase-plane controller's attitude [rad] and rate [rad/s] deadbands.
    allocator_rate_deadband_rad_s : float
        The allocator controller plans no new firing below this rate error [rad/s].
    allocator_trim_deadband_rad_s : float
        The allocator fires no plan that needs a minimum pulse while every axis's rate error
        is below this [rad/s] (no minimum-pulse trim pairs).
    maneuver_hysteresis_rad : float
        A maneuver entered above ``maneuver_limit_rad`` ends only below the limit minus this
        [rad] (0: enter and leave at the limit).
    min_pulse : str
        The minimum pulse policy, one of :data:`MIN_PULSE_POLICIES` (module docstring).
    allocation : str
        What the allocator minimises, one of :data:`ALLOCATION_MODES` (module docstring).
    source : str
        Where the values came from: the vehicle file, the keys it left to the paper's
        profile, and any overrides (a spec's ``[control]``, the command line).
    """

    cycle_s: float
    maneuver_rate_rad_s: float
    maneuver_limit_rad: float
    maneuver_band_rad: float
    rate_deadband_rad_s: float
    on_time_limit_s: float
    hold_time_s: float
    rate_case_rad_s: float
    phase_plane_att_deadband_rad: float
    phase_plane_rate_deadband_rad_s: float
    allocator_rate_deadband_rad_s: float
    allocator_trim_deadband_rad_s: float
    maneuver_hysteresis_rad: float
    min_pulse: str
    allocation: str
    source: str = ""

    def record(self) -> dict:
        """The profile as a manifest records it: file keys (degrees, seconds) -> values, and
        ``source``.  :func:`read_control` of the record (without ``source``) gives it back."""
        out: dict = {}
        for key, name, factor, _ in _KEYS:
            out[key] = _round_trip(getattr(self, name) / factor)
        for key in _CHOICE_KEYS:
            out[key] = getattr(self, key)
        out["source"] = self.source
        return out

    def values(self) -> dict:
        """File key -> value (degrees, seconds), without ``source``: what a spec's
        ``[control]`` or ``--control`` overrides."""
        rec = self.record()
        rec.pop("source")
        return rec

    def describe(self) -> str:
        """One line a report or a manifest shows: every value with its unit, and the source."""
        parts = [
            f"{key} = {value:g}" if isinstance(value, float) else f"{key} = {value}"
            for key, value in self.values().items()
        ]
        return f"{'; '.join(parts)} ({self.source})"


def _round_trip(value: float) -> float:
    """A converted value as the shortest decimal that reads back to the same degrees (0.2
    deg/s converted to rad/s and back is 0.20000000000000004)."""
    return float(f"{value:.12g}")


def read_control(
    raw: dict,
    base: ControlProfile | None,
    *,
    where: str,
    path: str = "control",
    bounds: bool = True,
) -> ControlProfile:
    """A profile from a ``[control]`` table ``raw`` (file keys, units in their names), each key
    it leaves out taken from ``base``; with ``base`` None every key is required.

    Parameters
    ----------
    raw : dict
        The table as parsed TOML (sub-tables ``phase_plane`` and ``allocator`` nested), or
        a flat dict with dotted keys (``"phase_plane.rate_deadband_deg_s"``).
    where : str
        The file or flag the table came from, for messages and :attr:`ControlProfile.source`.
    path : str
        The table's key path in messages (``control``).
    bounds : bool
        Check the bounds between keys (:func:`bound_problems`); False for a caller that
        checks them itself once every override is applied (a vehicle file, which knows its
        physics step: :func:`rcsim.spacecraft.vehicle.file_sections.check_profile`).

    Raises
    ------
    InputError
        An unknown key (the closest known one named), a value that is not a finite number or
        breaks its rule, a band not below the limit.  One line naming ``where``, the key and
        the value.
    """
    flat = flatten_control(raw, where, path)
    reader = Reader(flat, path, where)
    values: dict[str, float | str] = {}
    given: list[str] = []
    for key, name, factor, rule in _KEYS:
        if reader.has(key):
            value = reader.number(key, None, minimum=0.0, strict=rule == "pos")
            values[name] = value * factor
            given.append(key)
        elif base is not None:
            values[name] = getattr(base, name)
        else:
            raise reader.error(key, "is required")
    for key, words in _CHOICE_KEYS.items():
        if reader.has(key):
            values[key] = reader.choice(key, None, words)
            given.append(key)
        elif base is not None:
            values[key] = getattr(base, key)
        else:
            raise reader.error(key, f"is required; one of {', '.join(words)}")
    reader.done()
    if base is None:
        source = where
    elif given:
        source = f"{base.source}; {', '.join(given)} from {where}"
    else:
        source = base.source
    profile = ControlProfile(**values, source=source)  # type: ignore[arg-type]
    file_key = {name: key for key, name, _, _ in _KEYS} | {key: key for key in _CHOICE_KEYS}
    named = frozenset(name for name, key in file_key.items() if key in given)
    _check(
        profile,
        where=where,
        key_of=lambda name: f"{path}.{file_key[name]}",
        given=(named,) if bounds else None,
    )
    return profile


def flatten_control(raw: dict, where: str = "control", path: str = "control") -> dict:
    """Sub-tables ``phase_plane`` / ``allocator`` as dotted keys (unknown sub-tables are left
    as they are, for the reader to refuse by name)."""
    if not isinstance(raw, dict):
        raise InputError(f"{where}: {path}: expected a table, got {raw!r}")
    flat: dict = {}
    for key, value in raw.items():
        if isinstance(value, dict) and key in ("phase_plane", "allocator"):
            for sub, v in value.items():
                flat[f"{key}.{sub}"] = v
        else:
            flat[key] = value
    return flat


def parse_assignments(items: list[str] | tuple[str, ...], *, flag: str = "--control") -> dict:
    """``KEY=VALUE`` strings from the command line as a flat dict of numbers (of words for
    a key that takes one, e.g. ``min_pulse=drop``; the profile checks the word).

    A key may be written as messages and warnings spell it, with its table's name
    (``control.cycle_s``): it is the same key (``cycle_s``), not an unknown
    ``control.control.cycle_s``.

    Raises
    ------
    InputError
        An item without ``=`` or whose value is not a number, naming the flag and the item.
    """
    out: dict = {}
    for item in items:
        key, sep, text = item.partition("=")
        key, text = key.strip(), text.strip()
        key = key.removeprefix("control.")
        if not sep or not key:
            raise InputError(
                f"{flag}: expected KEY=VALUE, e.g. maneuver_limit_deg=0.8 (got {item!r})"
            )
        if key in _CHOICE_KEYS:
            out[key] = text
            continue
        try:
            value = float(text)
        except ValueError:
            raise InputError(f"{flag}: {key}: must be a number (got {text!r})") from None
        out[key] = value
    return out


def with_values(profile: ControlProfile, **si_values: float | str) -> ControlProfile:
    """``profile`` with fields replaced by SI values (code that retunes a profile for a
    study, e.g. ``with_values(p, maneuver_band_rad=0.0)``), checked as a file's values are;
    the source says which fields the code set."""
    names = {f.name for f in fields(ControlProfile)} - {"source"}
    unknown = sorted(set(si_values) - names)
    if unknown:
        raise InputError(f"ControlProfile has no field {unknown[0]!r}; fields: {sorted(names)}")
    if not si_values:
        return profile
    new = replace(
        profile,
        **si_values,  # type: ignore[arg-type]  # each field's type is _check's to refuse
        source=f"{profile.source}; {', '.join(si_values)} set in code",
    )
    _check(new, where="code", key_of=lambda name: name, given=(frozenset(si_values),))
    return new


def _check(profile: ControlProfile, *, where: str, key_of, given) -> None:
    """The rules every profile keeps, however made; ``key_of(field)`` names a field in the
    message (a file key, or the field itself for code).  ``given``: the fields this ``where``
    set (:func:`bound_problems`), or None to leave the bounds between keys to the caller."""
    for key, words in _CHOICE_KEYS.items():
        if getattr(profile, key) not in words:
            raise InputError(
                f"{where}: {key_of(key)}: must be one of {', '.join(words)} "
                f"(got {getattr(profile, key)!r})"
            )
    for _, name, _, rule in _KEYS:
        value = getattr(profile, name)
        ok = math.isfinite(value) and (value > 0 if rule == "pos" else value >= 0)
        if not ok:
            sign = ">" if rule == "pos" else ">="
            raise InputError(f"{where}: {key_of(name)}: must be {sign} 0 (got {value!r})")
    if not MIN_CYCLE_S <= profile.cycle_s <= MAX_CYCLE_S:
        raise InputError(
            f"{where}: {key_of('cycle_s')}: must be within {MIN_CYCLE_S:g} to {MAX_CYCLE_S:g} s "
            f"(a cycle in ms?) (got {profile.cycle_s!r})"
        )
    for name, text in bound_problems(profile, given) if given is not None else ():
        raise InputError(f"{where}: {key_of(name)}: {text} (got {shown_value(profile, name)})")


def shown_value(profile: ControlProfile, name: str) -> str:
    """Field ``name``'s value as its file key gives it (degrees, deg/s, s)."""
    return f"{_round_trip(getattr(profile, name) / _FACTOR[name]):g}"


def control_key(name: str) -> str:
    """Field ``name``'s key in a ``[control]`` table (``rate_deadband_rad_s`` ->
    ``rate_deadband_deg_s``)."""
    return _KEY_OF[name]


def _told(profile: ControlProfile, name: str) -> str:
    """``control.key = value unit``, how a message names another key's value."""
    return f"control.{control_key(name)} = {shown_value(profile, name)} {_UNIT[name]}"


def bound_problems(
    profile: ControlProfile, given: Sequence[frozenset[str] | set[str]] = ()
) -> list[tuple[str, str]]:
    """The profile's broken bounds, as (field, problem) pairs; empty when it keeps them all.

    Each bound is physical, from the profile's own values and its cycle (the vehicle's
    physics step bounds the rates: :func:`rate_problems`):

    * ``maneuver_limit_deg`` and ``phase_plane.attitude_deadband_deg`` below 180 deg: no
      attitude error is larger (a rotation's angle is at most 180 deg), so a limit at or above
      it never flies the maneuver rate, a deadband never fires;
    * ``maneuver_band_deg`` and ``maneuver_hysteresis_deg`` below the maneuver limit (the band
      lies on both sides of the limit; a maneuver ends below limit - hysteresis);
    * ``on_time_limit_s`` at most the cycle: a remaining on-time of a cycle or more is a firing
      still under way, and a limit above the cycle lets every cycle re-plan it;
    * ``hold_time_s`` at most ``maneuver_limit / maneuver_rate``: turning at the maneuver rate,
      a longer hold lets the vehicle cross the whole region inside the limit, where the
      controllers brake, without a firing;
    * the rate deadbands (lookup, phase plane, allocator and its trim deadband) below
      ``maneuver_rate / sqrt(3)``: a maneuver from rest along a diagonal starts with that
      per-axis rate error, the smallest a maneuver has on its largest axis, and a deadband at
      or above it leaves that maneuver unflown, no jet firing.

    A rule between fields names the first of them in the first of the ``given`` sets that
    holds one (sets of fields, most recently set first: the value just set is the one to
    blame), else the rule's first field.
    """
    p = profile
    out: list[tuple[str, str]] = []

    def blame(*names: str) -> str:
        for fields_set in given:
            for name in names:
                if name in fields_set:
                    return name
        return names[0]

    for name, what in (
        ("maneuver_limit_rad", "the maneuver rate would never be flown"),
        ("phase_plane_att_deadband_rad", "the phase plane would never fire on attitude"),
    ):
        if getattr(p, name) >= math.pi:
            out.append(
                (
                    name,
                    "must be below 180 deg: no attitude error is larger (a rotation's angle is "
                    f"at most 180 deg), so at or above it {what}",
                )
            )
    for name, why in (
        ("maneuver_hysteresis_rad", "a maneuver ends below limit - hysteresis"),
        ("maneuver_band_rad", "the band lies on both sides of the limit"),
    ):
        if getattr(p, name) >= p.maneuver_limit_rad:
            who = blame(name, "maneuver_limit_rad")
            if who == name:
                text = f"must be below the maneuver limit {_told(p, 'maneuver_limit_rad')} ({why})"
            else:
                text = f"must be above {_told(p, name)} ({why})"
            out.append((who, text))
    if p.on_time_limit_s > p.cycle_s * (1 + 1e-12):
        why = (
            "a remaining on-time of a cycle or more is a firing still under way, and a limit "
            "above the cycle lets every cycle re-plan a firing in progress"
        )
        who = blame("on_time_limit_s", "cycle_s")
        if who == "on_time_limit_s":
            text = f"must be at most the control cycle {_told(p, 'cycle_s')}: {why}"
        else:
            text = f"must be at least {_told(p, 'on_time_limit_s')}: {why}"
        out.append((who, text))
    most_hold_s = p.maneuver_limit_rad / p.maneuver_rate_rad_s
    if p.hold_time_s > most_hold_s * (1 + 1e-12):
        who = blame("hold_time_s", "maneuver_rate_rad_s", "maneuver_limit_rad")
        why = (
            "turning at the maneuver rate, a longer hold lets the vehicle cross the whole "
            "region inside the maneuver limit, where the controllers brake, without a firing"
        )
        ratio = f"{_told(p, 'maneuver_limit_rad')} / {_told(p, 'maneuver_rate_rad_s')}"
        if who == "hold_time_s":
            text = f"must be at most {ratio} = {most_hold_s:.4g} s: {why}"
        else:
            text = (
                f"makes {_told(p, 'hold_time_s')} longer than {ratio} = {most_hold_s:.4g} s: {why}"
            )
        out.append((who, text))
    diagonal = p.maneuver_rate_rad_s / math.sqrt(3.0)
    for name, whose in (
        ("rate_deadband_rad_s", "the lookup controller's"),
        ("phase_plane_rate_deadband_rad_s", "the phase plane's"),
        ("allocator_rate_deadband_rad_s", "the allocator's"),
        ("allocator_trim_deadband_rad_s", "the allocator's trim rule's"),
    ):
        if getattr(p, name) >= diagonal:
            who = blame(name, "maneuver_rate_rad_s")
            why = (
                "a maneuver from rest along a diagonal starts with a per-axis rate error of "
                f"maneuver_rate / sqrt(3) (the smallest a maneuver has on its largest axis), and "
                f"{whose} deadband at or above it leaves that maneuver unflown, no jet firing"
            )
            if who == name:
                text = (
                    f"must be below {_told(p, 'maneuver_rate_rad_s')} / sqrt(3) = "
                    f"{math.degrees(diagonal):.4g} deg/s: {why}"
                )
            else:
                text = (
                    f"must be above sqrt(3) x {_told(p, name)} = "
                    f"{math.degrees(getattr(p, name)) * math.sqrt(3.0):.4g} deg/s: {why}"
                )
            out.append((who, text))
    return out


def validated_rate_rad_s(timestep_s: float) -> float:
    """The largest body rate a vehicle's physics step ``timestep_s`` [s] is validated for
    [rad/s]: :data:`MAX_VALIDATED_RATE_DEG_S` at :data:`VALIDATED_STEP_S`, the same rotation
    per step at another step."""
    return math.radians(MAX_VALIDATED_RATE_DEG_S) * VALIDATED_STEP_S / timestep_s


def rate_problems(profile: ControlProfile, timestep_s: float) -> list[tuple[str, str]]:
    """The profile's rates against the vehicle's physics step ``timestep_s`` [s], as
    (field, problem) pairs: the maneuver rate and the rate cases' total rate at most
    :func:`validated_rate_rad_s` (faster, the flight's accuracy is not established; the
    maneuver rate at the braking the jets give is a warning,
    :mod:`rcsim.spacecraft.vehicle.sanity`; rate cases the jets cannot reach are refused
    by table generation)."""
    most = validated_rate_rad_s(timestep_s)
    out = []
    for name in ("maneuver_rate_rad_s", "rate_case_rad_s"):
        if getattr(profile, name) > most * (1 + 1e-12):
            out.append(
                (
                    name,
                    f"must be at most {math.degrees(most):.4g} deg/s, the largest rate the "
                    f"vehicle's {timestep_s * 1e3:g} ms physics step is validated for "
                    f"({MAX_VALIDATED_RATE_DEG_S:g} deg/s at {VALIDATED_STEP_S * 1e3:g} ms, "
                    "docs/convergence.md: the same rotation per step)",
                )
            )
    return out
