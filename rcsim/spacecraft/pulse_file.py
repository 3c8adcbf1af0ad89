"""A vehicle file's ``[pulse]`` and ``[propellant.blowdown]``: read, checked, and turned into
the flight's :class:`~rcsim.spacecraft.pulse_shape.PulseShape` and
:class:`~rcsim.spacecraft.blowdown.Blowdown`.

Every mistake is one :class:`~rcsim.models.errors.InputError` line naming the file, the key and
the value, as every vehicle-file key (``docs/vehicles.md``, "Pulses" and "Blowdown": the keys,
ranges and why each bound is what it is).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rcsim.models.errors import InputError
from rcsim.models.toml_reader import Reader
from rcsim.spacecraft.blowdown import Blowdown
from rcsim.spacecraft.pulse_draws import PULSE_SIGMA_KEYS
from rcsim.spacecraft.pulse_shape import (
    PULSE_MODELS,
    TAIL_CUT,
    ImpulseTable,
    IspTable,
    PulseShape,
)

#: Longest rise or tail-off [s]: 1 s, twenty times the slowest data-sheet transients of
#: attitude-control jets (tens of ms); a time in ms (1000x) is over.
MAX_TRANSIENT_S = 1.0
#: Cycles a tail may last after its valve closes: each one holds a valve slot per jet.
MAX_TAIL_CYCLES = 10
#: Range of the initial tank pressure [Pa]: 0.1 to 1000 bar -- monopropellant blowdown tanks
#: run 5-30 bar, composite pressurant bottles 300-700 bar; a pressure in bar (1e-5 x) or psi
#: (1.45e-4 x) of any of them is below.
PRESSURE_RANGE_PA = (1e4, 1e8)
#: Range of the propellant density [kg/m^3]: liquid propellants 700-1500 (hydrazine 1004, MMH
#: 880, NTO 1440); a density in g/cm^3 (1e-3 x) is below.
DENSITY_RANGE_KG_M3 = (100.0, 3000.0)
#: Range of the polytropic exponent: 1 (isothermal) to 5/3 (adiabatic monatomic helium).
POLYTROPIC_RANGE = (1.0, 5.0 / 3.0)
#: Largest exponent of thrust or Isp on the pressure (1: thrust proportional to pressure).
MAX_PRESSURE_EXPONENT = 2.0
#: The keys of ``[pulse]``, and those a ``[[jet]] pulse = {...}`` may override.
PULSE_KEYS = (
    "model",
    "rise_s",
    "tail_s",
    "on_time_s",
    "impulse_ns",
    "table_thrust_n",
    "isp_on_time_s",
    "isp_s",
)
JET_PULSE_KEYS = ("rise_s", "tail_s")
BLOWDOWN_KEYS = (
    "gas_volume_m3",
    "pressure_pa",
    "density_kg_m3",
    "polytropic_n",
    "thrust_exponent",
    "isp_exponent",
    "reference_pressure_pa",
)


@dataclass(frozen=True)
class PulseSpec:
    """A vehicle file's ``[pulse]``, nominal (per jet where a ``[[jet]]`` overrides it).

    Attributes
    ----------
    model : str
        One of :data:`~rcsim.spacecraft.pulse_shape.PULSE_MODELS`.
    rise_s, tail_s : tuple of float
        Per jet [s] (0 for a table).
    on_time_s, thrust_time_s : tuple of float
        The impulse-bit table: on-times [s] and impulse over the table's thrust [s]; empty
        unless ``model = "table"``.
    isp_on_time_s, isp_s : tuple of float
        Pulse-mode Isp table (empty: the steady Isp for every pulse).
    """

    model: str
    rise_s: tuple
    tail_s: tuple
    on_time_s: tuple = ()
    thrust_time_s: tuple = ()
    isp_on_time_s: tuple = ()
    isp_s: tuple = ()

    def shape(self, n_runs: int, steady_isp_s: float) -> PulseShape:
        """The flight's pulse shape for ``n_runs`` runs of the nominal vehicle."""
        rise = np.tile(np.asarray(self.rise_s, float), (n_runs, 1))
        tail = np.tile(np.asarray(self.tail_s, float), (n_runs, 1))
        table = (
            ImpulseTable(np.array(self.on_time_s), np.array(self.thrust_time_s))
            if self.model == "table"
            else None
        )
        isp = (
            IspTable(np.array(self.isp_on_time_s), np.array(self.isp_s), steady_isp_s)
            if self.isp_s
            else None
        )
        return PulseShape(self.model, rise, tail, table, None, isp)

    def describe(self) -> str:
        """One line: the model and its figures."""

        def ms(values) -> str:
            lo, hi = min(values) * 1e3, max(values) * 1e3
            return f"{lo:g} ms" if lo == hi else f"{lo:g}-{hi:g} ms"

        if self.model == "exponential":
            text = (
                f"first-order rise tau {ms(self.rise_s)}, tail-off tau {ms(self.tail_s)} "
                f"(cut after {TAIL_CUT:g} tau)"
            )
        elif self.model == "linear":
            text = f"linear rise {ms(self.rise_s)}, tail-off {ms(self.tail_s)}"
        else:
            text = (
                f"impulse-bit table of {len(self.on_time_s)} points up to "
                f"{self.on_time_s[-1] * 1e3:g} ms (linear between points, steady above)"
            )
        if self.isp_s:
            text += f"; pulse-mode Isp {min(self.isp_s):g}-{max(self.isp_s):g} s"
        return text


@dataclass(frozen=True)
class BlowdownSpec:
    """A vehicle file's ``[propellant.blowdown]``, SI (a :class:`~.blowdown.Blowdown`)."""

    gas_volume_m3: float
    pressure_pa: float
    density_kg_m3: float
    polytropic_n: float = 1.0
    thrust_exponent: float = 1.0
    isp_exponent: float = 0.0
    reference_pressure_pa: float = 0.0  # 0: pressure_pa

    def blowdown(self, n_runs: int) -> Blowdown:
        """The flight's blowdown for ``n_runs`` runs of the nominal vehicle."""
        return Blowdown(
            self.gas_volume_m3,
            np.full(n_runs, self.pressure_pa),
            self.density_kg_m3,
            self.polytropic_n,
            self.thrust_exponent,
            self.isp_exponent,
            self.reference_pressure_pa or self.pressure_pa,
        )

    def describe(self, propellant_kg: float) -> str:
        """One line: the law and the thrust left when the tank is empty."""
        end = self.blowdown(1)
        factor = float(end.thrust_factor(np.array([propellant_kg]))[0])
        p_end = float(end.pressure(np.array([propellant_kg]))[0])
        return (
            f"blowdown {self.pressure_pa / 1e5:g} bar on {self.gas_volume_m3 * 1e3:g} L of gas "
            f"(P V^{self.polytropic_n:g} constant, thrust ~ P^{self.thrust_exponent:g}, "
            f"Isp ~ P^{self.isp_exponent:g}): {p_end / 1e5:.4g} bar and "
            f"{factor * 100:.1f} % thrust when the propellant is used up"
        )


def _table(r: Reader, name: str, positive: bool) -> tuple:
    value = r.raw(name, None)
    ok = (
        isinstance(value, list)
        and len(value) >= 1
        and all(
            isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
            for v in value
        )
    )
    if not ok:
        raise r.error(name, "must be a list of finite numbers", value)
    values = tuple(float(v) for v in value)
    if positive and min(values) <= 0:
        raise r.error(name, "must be > 0", value)
    if not positive and min(values) < 0:
        raise r.error(name, "must be >= 0", value)
    return values


def _on_times(r: Reader, name: str, cycle_s: float) -> tuple:
    on = _table(r, name, positive=True)
    if any(b <= a for a, b in zip(on, on[1:])):
        raise r.error(name, "must be strictly increasing (a table is monotone)", list(on))
    if on[-1] >= cycle_s:
        raise r.error(
            name,
            f"must be shorter than the {cycle_s * 1e3:g} ms control cycle: a longer pulse is "
            "commanded over several cycles, at steady state above the table (on-times in ms?)",
            list(on),
        )
    return on


def _transient_problem(name: str, value: float, model: str, cycle_s: float) -> str:
    """Why a rise or tail ``value`` [s] is refused, or ''."""
    if value >= MAX_TRANSIENT_S:
        return (
            f"must be below {MAX_TRANSIENT_S:g} s, twenty times the slowest jet transients "
            "(tens of ms): a time in ms?"
        )
    length = TAIL_CUT * value if model == "exponential" else value
    if name == "tail_s" and length > MAX_TAIL_CYCLES * cycle_s:
        what = f"{TAIL_CUT:g} time constants" if model == "exponential" else "the tail-off"
        return (
            f"{what} ({length * 1e3:.4g} ms) must end within {MAX_TAIL_CYCLES} control "
            f"cycles ({MAX_TAIL_CYCLES * cycle_s * 1e3:g} ms)"
        )
    return ""


def _transient(r: Reader, name: str, model: str, cycle_s: float, default=None) -> float:
    value = r.number(name, default, minimum=0.0)
    problem = _transient_problem(name, value, model, cycle_s)
    if problem:
        raise r.error(name, problem, value)
    return value


def read_pulse(
    top: Reader,
    raw_jets: list,
    raw_defaults: dict,
    cycle_s: float,
    isp_range_s: tuple,
) -> PulseSpec | None:
    """``[pulse]`` and each ``[[jet]] pulse = {rise_s, tail_s}`` override (popped from the
    raw jet tables, before the jets are read); None without a ``[pulse]``.

    ``raw_defaults``: ``[jet_defaults]`` as written (a ``pulse`` there is refused: the
    vehicle-wide values are ``[pulse]``'s)."""
    src = top.source
    if isinstance(raw_defaults, dict) and "pulse" in raw_defaults:
        raise InputError(
            f"{src}: jet_defaults.pulse: the vehicle-wide pulse is [pulse]; a [[jet]] block may "
            "override its rise_s and tail_s"
        )
    overrides = []
    for k, raw in enumerate(raw_jets if isinstance(raw_jets, list) else []):
        own = raw.pop("pulse", None) if isinstance(raw, dict) else None
        overrides.append((k, own))
    if not top.has("pulse"):
        for k, own in overrides:
            if own is not None:
                raise InputError(
                    f"{src}: jet[{k + 1}].pulse: needs a [pulse] section (the model) (got {own!r})"
                )
        return None
    p = top.table_("pulse")
    model = p.choice("model", None, PULSE_MODELS)
    rise = tail = 0.0
    on: tuple = ()
    thrust_time: tuple = ()
    if model == "table":
        for key in ("rise_s", "tail_s"):
            if p.has(key):
                raise p.error(key, "not with model = 'table': the table is the pulse", p.raw(key))
        on = _on_times(p, "on_time_s", cycle_s)
        impulse = _table(p, "impulse_ns", positive=False)
        if len(impulse) != len(on):
            raise p.error(
                "impulse_ns",
                f"must have one value per on_time_s point ({len(on)})",
                list(impulse),
            )
        if any(b < a for a, b in zip(impulse, impulse[1:])):
            raise p.error(
                "impulse_ns",
                "must not decrease with the on-time (a table is monotone)",
                list(impulse),
            )
        thrusts = _jet_thrusts(raw_jets, raw_defaults)
        if p.has("table_thrust_n"):
            f_table = p.number("table_thrust_n", None, minimum=0.0, strict=True)
        elif len(thrusts) == 1:
            f_table = thrusts.pop()
        else:
            raise p.error(
                "table_thrust_n",
                "is required when the jets' thrusts differ: the thrust the table's impulses "
                "are given for (each jet's scale with its own thrust)",
            )
        thrust_time = tuple(i / f_table for i in impulse)
        excess = max(t - u for t, u in zip(thrust_time, on))
        if excess >= cycle_s:
            raise p.error(
                "impulse_ns",
                f"a point delivers {excess * 1e3:.4g} ms of full thrust more than its "
                f"on-time, over a {cycle_s * 1e3:g} ms control cycle: an impulse in mN s?",
                list(impulse),
            )
    else:
        for key in ("on_time_s", "impulse_ns", "table_thrust_n"):
            if p.has(key):
                raise p.error(key, "only with model = 'table'", p.raw(key))
        rise = _transient(p, "rise_s", model, cycle_s, 0.0)
        tail = _transient(p, "tail_s", model, cycle_s, 0.0)
    isp_on: tuple = ()
    isp: tuple = ()
    if p.has("isp_s") or p.has("isp_on_time_s"):
        isp_on = _on_times(p, "isp_on_time_s", cycle_s)
        isp = _table(p, "isp_s", positive=True)
        if len(isp) != len(isp_on):
            raise p.error(
                "isp_s", f"must have one value per isp_on_time_s point ({len(isp_on)})", list(isp)
            )
        lo, hi = isp_range_s
        if min(isp) < lo or max(isp) > hi:
            raise p.error(
                "isp_s",
                f"must be within {lo:g} to {hi:g} s, as propellant.isp_s (an exhaust velocity "
                "in m/s?)",
                list(isp),
            )
    p.done()
    rises, tails = [], []
    for k, own in overrides:
        r_k, t_k = rise, tail
        if own is not None:
            jr = Reader(own, f"jet[{k + 1}].pulse", src)
            if model == "table":
                raise jr.error("rise_s", "not with model = 'table'", own)
            r_k = _transient(jr, "rise_s", model, cycle_s, rise)
            t_k = _transient(jr, "tail_s", model, cycle_s, tail)
            jr.done()
        rises.append(r_k)
        tails.append(t_k)
    return PulseSpec(model, tuple(rises), tuple(tails), on, thrust_time, isp_on, isp)


def _jet_thrusts(raw_jets, raw_defaults) -> set:
    default = raw_defaults.get("thrust_n") if isinstance(raw_defaults, dict) else None
    out = set()
    for raw in raw_jets if isinstance(raw_jets, list) else []:
        value = raw.get("thrust_n", default) if isinstance(raw, dict) else default
        if isinstance(value, (int, float)) and not isinstance(value, bool) and value > 0:
            out.add(float(value))
    return out


def _ranged(r: Reader, name: str, default, lo: float, hi: float, why: str) -> float:
    value = r.number(name, default, minimum=0.0, strict=True)
    if not lo <= value <= hi:
        raise r.error(name, f"must be within {lo:g} to {hi:g}: {why}", value)
    return value


def read_blowdown(pr: Reader, propellant_kg: float | None) -> BlowdownSpec | None:
    """``[propellant.blowdown]`` (popped from ``[propellant]``'s reader); None without one."""
    if not pr.has("blowdown"):
        return None
    b = pr.table_("blowdown")
    if propellant_kg is None:
        raise b.error("pressure_pa", "needs propellant.mass_kg: the pressure follows its use")
    volume = b.number("gas_volume_m3", None, minimum=0.0, strict=True)
    if volume > 100.0:
        raise b.error(
            "gas_volume_m3",
            "must be at most 100 m^3, a tank the size of a house: a volume in litres?",
            volume,
        )
    pressure = _ranged(
        b,
        "pressure_pa",
        None,
        *PRESSURE_RANGE_PA,
        "0.1 to 1000 bar, cold-gas and blowdown tanks to COPVs (a pressure in bar or psi?)",
    )
    density = _ranged(
        b,
        "density_kg_m3",
        None,
        *DENSITY_RANGE_KG_M3,
        "liquid propellants (hydrazine 1004, MMH 880, NTO 1440; a density in g/cm^3?)",
    )
    n = _ranged(b, "polytropic_n", 1.0, *POLYTROPIC_RANGE, "1 isothermal to 5/3 adiabatic helium")
    a = b.number("thrust_exponent", 1.0, minimum=0.0)
    c = b.number("isp_exponent", 0.0, minimum=0.0)
    for key, value in (("thrust_exponent", a), ("isp_exponent", c)):
        if value > MAX_PRESSURE_EXPONENT:
            raise b.error(
                key, f"must be at most {MAX_PRESSURE_EXPONENT:g} (1: proportional to P)", value
            )
    ref = (
        _ranged(b, "reference_pressure_pa", None, *PRESSURE_RANGE_PA, "as pressure_pa")
        if b.has("reference_pressure_pa")
        else 0.0
    )
    b.done()
    return BlowdownSpec(volume, pressure, density, n, a, c, ref)


#: A minimum pulse whose shaped impulse is below this share of the square pulse's earns a
#: warning: the controllers' tables and plans price pulses as square ones.
MIN_BIT_SHARE = 0.5
#: A pulse-mode Isp table whose last point is farther than this from the steady Isp jumps
#: there (the steady value takes over above the table).
ISP_JUMP = 0.10
#: Thrust share left at an empty tank below which a blowdown earns a warning: blowdown ratios
#: of flown monopropellant systems are about 4:1 or less.
MIN_END_THRUST = 0.25


def pulse_warnings(
    pulse: PulseSpec | None,
    blowdown: BlowdownSpec | None,
    *,
    min_on_s: float,
    isp_s: float,
    propellant_kg: float | None,
) -> list[str]:
    """The warnings a vehicle file's ``[pulse]`` and ``[propellant.blowdown]`` earn
    (``docs/vehicles.md``, "Warnings"), one line each."""
    out = []
    if pulse is not None and min_on_s > 0:
        share = pulse.shape(1, isp_s).thrust_time_s(np.full((1, len(pulse.rise_s) or 1), min_on_s))
        low = float(share.min()) / min_on_s
        if low < MIN_BIT_SHARE:
            out.append(
                f"pulse: the minimum pulse (min_on_s = {min_on_s * 1e3:g} ms) delivers "
                f"{low * 100:.3g} % of a square pulse's impulse, below {MIN_BIT_SHARE * 100:g} %: "
                "the lookup tables and the allocator price pulses as square ones, so small "
                "corrections fall short (raise min_on_s, or check the rise time's units)"
            )
    if pulse is not None and pulse.isp_s:
        jump = abs(pulse.isp_s[-1] - isp_s) / isp_s
        if jump > ISP_JUMP:
            out.append(
                f"pulse.isp_s: the last point's {pulse.isp_s[-1]:g} s is {jump * 100:.3g} % from "
                f"propellant.isp_s = {isp_s:g} s, which takes over above "
                f"{pulse.isp_on_time_s[-1] * 1e3:g} ms: the Isp jumps there (extend the table?)"
            )
    if blowdown is not None and propellant_kg is not None:
        end = float(blowdown.blowdown(1).thrust_factor(np.array([propellant_kg]))[0])
        if end < MIN_END_THRUST:
            out.append(
                f"propellant.blowdown: the thrust falls to {end * 100:.3g} % of nominal when "
                f"the {propellant_kg:g} kg are used, below {MIN_END_THRUST * 100:g} % (blowdown "
                "ratios flown are about 4:1 or less): more pressurant gas_volume_m3, or a "
                "volume in other units?"
            )
    return out


def read_pulse_dispersions(
    ds: Reader, pulse: PulseSpec | None, blowdown: BlowdownSpec | None, cycle_s: float
) -> dict:
    """The ``[dispersions]`` keys of real pulses and blowdown (popped from its reader before
    the mass-property keys are read): key -> 3-sigma (SI; :mod:`rcsim.spacecraft.pulse_draws`).
    Each needs the section it disperses, and its 3-sigma draw must stay physical."""
    out: dict = {}
    for key in PULSE_SIGMA_KEYS:
        if not ds.has(key):
            continue
        value = ds.number(key, None, minimum=0.0)
        if key in ("pulse_rise_s", "pulse_tail_s"):
            if pulse is None or pulse.model == "table":
                raise ds.error(key, "needs [pulse] with model = 'exponential' or 'linear'", value)
            nominal = max(pulse.rise_s if key == "pulse_rise_s" else pulse.tail_s)
            problem = _transient_problem(key[6:], nominal + value, pulse.model, cycle_s)
            if problem:
                raise ds.error(
                    key, f"the longest nominal {nominal:g} s plus 3-sigma {problem}", value
                )
        elif key == "impulse_bit":
            if pulse is None or pulse.model != "table":
                raise ds.error(
                    key,
                    "needs [pulse] with model = 'table' (a first-order or linear pulse's "
                    "scatter is pulse_rise_s and pulse_tail_s)",
                    value,
                )
            if value >= 1.0:
                raise ds.error(
                    key,
                    "must be below 1 (a relative 3-sigma): a 3-sigma draw must deliver an impulse",
                    value,
                )
        else:
            if blowdown is None:
                raise ds.error(key, "needs [propellant.blowdown]", value)
            if value >= blowdown.pressure_pa:
                raise ds.error(
                    key,
                    f"must be below propellant.blowdown.pressure_pa = {blowdown.pressure_pa:g}: "
                    "a 3-sigma draw must stay a pressure",
                    value,
                )
        out[key] = value
    return out


def pulse_check_lines(
    pulse: PulseSpec | None,
    blowdown: BlowdownSpec | None,
    *,
    min_on_s: float,
    isp_s: float,
    propellant_kg: float | None,
    n_jets: int,
    authority: dict,
) -> list[str]:
    """What ``rcsim vehicle check`` says of the pulses: the model, the rate change one
    minimum impulse bit gives per axis direction (``authority``: direction name -> the pure-
    axis angular acceleration of the jets at full thrust [rad/s^2]; the bit is the shaped
    pulse at ``min_on_s``: ``alpha * I(min_on_s) / F``), and the blowdown."""
    out = [f"pulses: {'square (no [pulse])' if pulse is None else pulse.describe()}"]
    if min_on_s <= 0:
        out.append("minimum impulse bit: none (min_on_s = 0: pulses as short as commanded)")
    else:
        if pulse is None:
            full_s = np.full(n_jets, min_on_s)
        else:
            full_s = pulse.shape(1, isp_s).thrust_time_s(np.full((1, n_jets), min_on_s))[0]
        lo, hi = float(full_s.min()), float(full_s.max())
        share = (
            f"{lo / min_on_s * 100:.3g} %"
            if lo == hi
            else (f"{lo / min_on_s * 100:.3g}-{hi / min_on_s * 100:.3g} %")
        )

        def rate(alpha: float) -> str:
            if alpha <= 0:
                return "-"
            a, b = math.degrees(alpha * lo), math.degrees(alpha * hi)
            return f"{a:.3g}" if a == b else f"{a:.3g}-{b:.3g}"

        rates = ", ".join(f"{name} {rate(alpha)}" for name, alpha in authority.items())
        out.append(
            f"minimum impulse bit (min_on_s = {min_on_s * 1e3:g} ms, {share} of a square "
            f"pulse's impulse): rate change per bit of the jets with full authority [deg/s]: "
            f"{rates}"
        )
    if blowdown is not None and propellant_kg is not None:
        out.append(blowdown.describe(propellant_kg))
    return out
