"""What the data say about how runs fail: one paragraph per significant driver family.

The driver ranking says *which* inputs differ between failed and successful runs; this module
turns it into sentences a reader can check against the tables, every number computed from the
runs (nothing about the physics is assumed):

* **which input and which side** -- the family's leading factor, its failure region (from the
  driver table, in the input's units) read as its high side, low side or a middle band, the
  share of all runs and of all failures inside it, and the failure rate inside against
  outside;
* **which axis fails** -- per axis, the share of the region's failed runs that end with that
  axis's rate error at or past the failure threshold, against the successful runs' share;
* **how the firings differ** -- firing events on that axis's jets (``firings_{axis}``), those
  after the commanded rate was first reached (``firings_{axis} - firings_to_rate_{axis}``,
  "corrective" firings) and the time that rate was first reached (``time_to_rate_{axis}_s``),
  failed runs of the region against successful runs; the words "more" or "later" are used only
  when the difference is clear (a quarter more and at least half a firing, or 10 % and 0.2 s).

A *family* is a significant factor together with the lower-ranked significant factors that are
another view of the same quantity: the same name up to the jet-group direction
(``authority_yaw_fire_rad_s2`` and ``authority_yaw_pos_rad_s2``) or a rank correlation of at
least :data:`FAMILY_CORRELATION` with it over the runs (a group's authority and the inertia it
divides by).  Columns are those of :mod:`rcsim.analysis.engine.runs_table`; a run table without
outcome columns gets the sentences it can support and no more.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from rcsim.analysis.engine import runs_table
from rcsim.analysis.results.report.html import Section, text_block
from rcsim.lookup.table_edits import axis_cycles, jet_axes
from rcsim.models.errors import InputError
from rcsim.models.tables import PAPER_CYCLE_S, load_lookup_table

#: Two significant factors whose Spearman correlation over the runs reaches this are one family.
FAMILY_CORRELATION = 0.5
#: Families described, strongest first.
MAX_FAMILIES = 4

_AXES = ("roll", "pitch", "yaw")
_DIRS = {"fire": "firing-direction", "pos": "positive", "neg": "negative"}
_UNITS = (
    ("_rad_s2", "rad/s^2"),
    ("_kg_m2", "kg m^2"),
    ("_deg_s", "deg/s"),
    ("_deg", "deg"),
    ("_kg", "kg"),
    ("_n", "N"),
    ("_m", "m"),
    ("_s", "s"),
)


@dataclass
class Mechanism:
    """What the runs show about one driver family (numbers as fractions, not percent).

    Attributes
    ----------
    factor : str
        The family's leading (highest-ranked) significant factor.
    description : str
        What it is, in words.
    side : {"high", "low", "middle", "several", "none"}
        Where its failure region lies in the factor's range.
    region : str
        The failure region as the driver table gives it (input units).
    unit : str
    run_share, fail_share : float
        Share of all runs / of all failed runs inside the region.
    fail_rate_in, fail_rate_out : float
        Failure rate inside / outside the region.
    axis : str or None
        The axis whose final rate error fails most often among the region's failed runs.
    axis_fail_share, axis_success_share : dict
        Per axis, the share of the region's failed runs / of all successful runs ending with
        ``|final rate error| >= threshold`` (or, without a threshold, above the successful
        runs' 95th percentile).
    firings : dict
        For ``axis``: mean ``firings``, mean ``late`` (after first reaching the rate), median
        ``time_to_rate_s`` and ``never`` (share never reaching it), each as ``(failed,
        successful)``; keys present only when the columns are.
    table_firing : dict
        The lookup table's firing time on ``axis`` [s] in the cases the region's failed runs
        come from (most failures first), when the campaign flew a lookup table.
    table : str
        That table's name.
    members : list of str
        The family's other significant factors.
    text : str
        The paragraph.
    """

    factor: str
    description: str
    side: str
    region: str
    unit: str
    run_share: float
    fail_share: float
    fail_rate_in: float
    fail_rate_out: float
    axis: str | None = None
    axis_fail_share: dict = field(default_factory=dict)
    axis_success_share: dict = field(default_factory=dict)
    firings: dict = field(default_factory=dict)
    table_firing: dict = field(default_factory=dict)
    table: str = ""
    members: list = field(default_factory=list)
    text: str = ""


def unit_of(factor: str) -> str:
    """The unit of an input: its runs-table unit, else read from the name's suffix."""
    col = runs_table.column_named(factor)
    if col is not None:
        return "" if col.unit == "-" else col.unit
    if factor.startswith("pointing_loss_"):
        return ""
    for suffix, unit in _UNITS:
        if factor.endswith(suffix):
            return unit
    return ""


def describe(factor: str) -> str:
    """An input in words (the physics-aware factors as :mod:`~.factors` defines them)."""
    m = re.fullmatch(
        r"(authority|thrust|imbalance|pointing_loss)_(\w+?)_(pos|neg|fire)(_.*)?", factor
    )
    if m and m.group(2) in _AXES:
        kind, axis, d = m.group(1), m.group(2), m.group(3)
        what = {
            "authority": "authority",
            "thrust": "total thrust",
            "imbalance": "thrust imbalance",
            "pointing_loss": "torque lost to jet misalignment",
        }[kind]
        group = "pair" if kind == "imbalance" else "group"  # imbalance: pairs only (factors)
        return f"the {axis} {_DIRS[d]} jet {group}'s {what}"
    m = re.fullmatch(r"jet_(\d+)_(thrust_n|tilt_deg|azimuth_deg)", factor)
    if m:
        part = {"thrust_n": "thrust", "tilt_deg": "tilt", "azimuth_deg": "tilt azimuth"}
        return f"jet {int(m.group(1))}'s {part[m.group(2)]}"
    m = re.fullmatch(r"i(xx|yy|zz)_kg_m2", factor)
    if m:
        return f"the moment of inertia about {m.group(1)[0]} (I{m.group(1)})"
    m = re.fullmatch(r"cg_([xyz])_m", factor)
    if m:
        return f"the centre of gravity's {m.group(1)} position"
    col = runs_table.column_named(factor)
    if col is not None:
        return col.meaning.replace(" (read back)", "").replace(" (the draw)", "")
    return factor


def _family_key(factor: str) -> str:
    return re.sub(r"_(pos|neg|fire)(?=_|$)", "", factor)


def _parse_region(region: str):
    """``(side, [(lo, hi), ...])`` of a driver table's failure region text."""
    if not isinstance(region, str) or not region.strip():
        return "none", []
    parts = []
    for part in region.split(" or "):
        part = part.strip()
        if part == "everywhere":
            parts.append((-np.inf, np.inf))
        elif part.startswith("<="):
            parts.append((-np.inf, float(part[2:])))
        elif part.startswith(">="):
            parts.append((float(part[2:]), np.inf))
        else:
            lo, _, hi = part.partition("..")
            parts.append((float(lo), float(hi)))
    if len(parts) > 1:
        side = "several"
    elif np.isinf(parts[0][0]) and np.isinf(parts[0][1]):
        side = "none"
    elif np.isinf(parts[0][1]):
        side = "high"
    elif np.isinf(parts[0][0]):
        side = "low"
    else:
        side = "middle"
    return side, parts


def _pct(x: float) -> str:
    return f"{100.0 * x:.0f}\u00a0%"  # no line break between a number and its sign


def _num(x: float) -> str:
    return f"{x:.3g}"


def families(drivers: pd.DataFrame, X: pd.DataFrame) -> list[list[str]]:
    """The significant factors grouped into families, strongest family first; each family's
    leader first (see the module docstring)."""
    sig = [f for f in drivers.loc[drivers["significant"].astype(bool), "factor"] if f in X]
    out: list[list[str]] = []
    for f in sig:
        for fam in out:
            lead = fam[0]
            same = _family_key(f) == _family_key(lead)
            if same or abs(X[f].corr(X[lead], method="spearman")) >= FAMILY_CORRELATION:
                fam.append(f)
                break
        else:
            out.append([f])
    return out


def _threshold(runset) -> float | None:
    t = (runset.manifest or {}).get("thresholds", {}).get("rate_error_deg_s")
    return None if t is None else float(t)


def explain(
    factor: str,
    region: str,
    x: np.ndarray,
    y: np.ndarray,
    runs: pd.DataFrame,
    threshold: float | None = None,
    fail_share: float | None = None,
    run_share: float | None = None,
    strata: np.ndarray | None = None,
    manifest: dict | None = None,
) -> Mechanism:
    """The mechanism of one factor: region, failing axis and firings (module docstring).

    Parameters
    ----------
    factor : str
    region : str
        Its failure region as :class:`~.single.SingleFactorKDE` formats it.
    x : ndarray (n,)
        The factor's value in every run.
    y : ndarray of bool (n,)
        True for a failed run.
    runs : DataFrame (n rows)
        The runs' outcome columns (any of them may be missing).
    threshold : float, optional
        The rate-error failure threshold [deg/s].
    fail_share, run_share : float, optional
        The driver table's shares (default: counted here from ``region``).
    strata : ndarray (n,), optional
        Case of every run: failed runs are then compared with the successful runs of the
        cases they fail in (a case that never fires about an axis says nothing about it).
    manifest : dict, optional
        The campaign's manifest: with a lookup-table controller, the table's firing time on
        the failing axis in the failed runs' cases is stated.
    """
    x, y = np.asarray(x, float), np.asarray(y, bool)
    side, parts = _parse_region(region)
    inside = np.zeros(x.size, bool)
    for lo, hi in parts:
        inside |= (x >= lo) & (x <= hi)
    n_fail = max(int(y.sum()), 1)
    mech = Mechanism(
        factor=factor,
        description=describe(factor),
        side=side,
        region=region if isinstance(region, str) else "",
        unit=unit_of(factor),
        run_share=float(inside.mean()) if run_share is None else float(run_share),
        fail_share=float((inside & y).sum() / n_fail) if fail_share is None else float(fail_share),
        fail_rate_in=float(y[inside].mean()) if inside.any() else float("nan"),
        fail_rate_out=float(y[~inside].mean()) if (~inside).any() else float("nan"),
    )
    focus = y & inside if (y & inside).any() else y
    ok = ~y
    if strata is not None:
        strata = np.asarray(strata)
        same = ok & np.isin(strata, np.unique(strata[focus]))
        ok = same if same.any() else ok
    _axis(mech, runs.reset_index(drop=True), focus, ok, threshold)
    _firings(mech, runs.reset_index(drop=True), focus, ok)
    if strata is not None:
        names, counts = np.unique(np.asarray(strata)[focus], return_counts=True)
        _table_firing(mech, manifest, list(names[np.argsort(-counts, kind="stable")][:3]))
    mech.text = _paragraph(mech, threshold)
    return mech


def _axis(mech: Mechanism, runs, failed, ok, threshold) -> None:
    if not ok.any():
        return
    for axis in _AXES:
        col = f"final_rate_err_{axis}_deg_s"
        if col not in runs:
            continue
        err = np.abs(runs[col].to_numpy(float))
        if threshold is not None:
            off = err >= threshold
        else:  # no failure threshold known: "off" is beyond 95 % of the successful runs
            off = err > np.nanquantile(err[ok], 0.95)
        mech.axis_fail_share[axis] = float(np.mean(off[failed]))
        mech.axis_success_share[axis] = float(np.mean(off[ok]))
    if mech.axis_fail_share:
        best = max(mech.axis_fail_share, key=lambda a: mech.axis_fail_share[a])
        if mech.axis_fail_share[best] > mech.axis_success_share[best]:
            mech.axis = best


def _firings(mech: Mechanism, runs, failed, ok) -> None:
    a = mech.axis
    if a is None or not ok.any():
        return
    fire, to_rate, t = f"firings_{a}", f"firings_to_rate_{a}", f"time_to_rate_{a}_s"
    if fire in runs:
        f = runs[fire].to_numpy(float)
        mech.firings["firings"] = (float(np.nanmean(f[failed])), float(np.nanmean(f[ok])))
        if to_rate in runs:
            late = f - runs[to_rate].to_numpy(float)
            mech.firings["late"] = (float(np.nanmean(late[failed])), float(np.nanmean(late[ok])))
    if t in runs:
        tt = runs[t].to_numpy(float)
        mech.firings["never"] = (
            float(np.mean(np.isnan(tt[failed]))),
            float(np.mean(np.isnan(tt[ok]))),
        )
        if np.isfinite(tt[failed]).any() and np.isfinite(tt[ok]).any():
            mech.firings["time_to_rate_s"] = (
                float(np.nanmedian(tt[failed])),
                float(np.nanmedian(tt[ok])),
            )


def _table_firing(mech: Mechanism, manifest: dict | None, cases) -> None:
    """The flown lookup table's firing time on the failing axis in ``cases`` (rate-NN)."""
    ctrl = (manifest or {}).get("spec", {}).get("controller", {})
    if mech.axis is None or ctrl.get("name") != "lookup" or not ctrl.get("table"):
        return
    try:
        table = load_lookup_table(ctrl["table"])
        # The cycle the campaign flew (its manifest's; the paper's for one written before).
        cycle_s = float((manifest or {}).get("control_cycle_s", PAPER_CYCLE_S))
        cycles = axis_cycles(table.firing_time_s, jet_axes(table), cycle_s)
    except (InputError, OSError, ValueError):  # a table file no longer where it was
        return
    a = _AXES.index(mech.axis)
    for case in cases:
        kind, _, num = str(case).partition("-")
        if kind == "rate" and num.isdigit() and int(num) in table.case:
            row = int(np.flatnonzero(table.case == int(num))[0])
            mech.table_firing[str(case)] = float(cycles[row, a] * cycle_s)
    mech.table = str(ctrl["table"]).replace("\\", "/").split("/")[-1]


def _more(a: float, b: float, rel: float, absolute: float) -> str:
    """'more', 'fewer' or 'about as many' (a against b)."""
    if a - b >= max(absolute, rel * abs(b)):
        return "more"
    if b - a >= max(absolute, rel * abs(a)):
        return "fewer"
    return "about as many"


def _paragraph(m: Mechanism, threshold: float | None) -> str:
    unit = f" {m.unit}" if m.unit else ""
    where = {
        "high": lambda: f"high (its top {_pct(m.run_share)} of runs, {m.region}{unit})",
        "low": lambda: f"low (its bottom {_pct(m.run_share)} of runs, {m.region}{unit})",
        "middle": lambda: (
            f"in a middle band ({m.region.replace('..', 'to')}{unit}, {_pct(m.run_share)} of runs)"
        ),
        "several": lambda: f"in {m.region}{unit} ({_pct(m.run_share)} of runs)",
        "none": lambda: "",
    }[m.side]()
    if not where:
        return (
            f"{m.factor} ({m.description}) is a significant driver, but no part of its range "
            "reaches twice the base failure rate: its effect is spread over the whole range."
        )
    out = [
        f"Runs fail when {m.description} ({m.factor}) is {where}: runs there fail at "
        f"{_pct(m.fail_rate_in)} against {_pct(m.fail_rate_out)} elsewhere, and they hold "
        f"{_pct(m.fail_share)} of all failures."
    ]
    if m.axis is not None:
        limit = (
            f">= {threshold:g} deg/s"
            if threshold is not None
            else "above the successful runs' 95th percentile"
        )
        others = [a for a in m.axis_fail_share if a != m.axis]
        rest = ", ".join(f"{a} {_pct(m.axis_fail_share[a])}" for a in others)
        out.append(
            f"It is the {m.axis} rate that is off: {_pct(m.axis_fail_share[m.axis])} of these "
            f"failed runs end with |{m.axis} rate error| {limit} "
            f"(successful runs of the same cases: {_pct(m.axis_success_share[m.axis])}"
            + (f"; the other axes: {rest} of the failed runs" if rest else "")
            + ")."
        )
    if m.table_firing:
        times = ", ".join(f"{t:.2f} s ({c})" for c, t in m.table_firing.items())
        out.append(
            f"In the cases with most of these failures the table flown ({m.table}) fires the "
            f"{m.axis} jets for {times}."
        )
    fr = m.firings
    if "firings" in fr:
        (ff, fs) = fr["firings"]
        how = {"more": "more often than", "fewer": "less often than"}
        s = (
            f"The failed runs fire the {m.axis} jets {ff:.1f} times on average, "
            f"{how.get(_more(ff, fs, 0.25, 0.5), 'about as often as')} the successful runs "
            f"of the same cases ({fs:.1f})"
        )
        if "late" in fr:
            lf, ls = fr["late"]
            s += (
                f"; {lf:.1f} of those firings come after the commanded rate was first "
                f"reached (successful runs: {ls:.1f})"
            )
            if _more(lf, ls, 0.25, 0.5) == "more":
                s += ", so late corrective firings follow"
        out.append(s + ".")
    never = ""
    if fr.get("never", (0.0, 0.0))[0] > 0:
        nf, ns = fr["never"]
        within = f"within {threshold:g} deg/s of" if threshold is not None else "to"
        never = (
            f"{_pct(nf)} of the failed runs never come {within} the commanded {m.axis} rate "
            f"(successful runs: {_pct(ns)})"
        )
    if "time_to_rate_s" in fr:
        tf, ts = fr["time_to_rate_s"]
        later = tf - ts >= max(0.2, 0.1 * abs(ts))
        earlier = ts - tf >= max(0.2, 0.1 * abs(tf))
        word = "later" if later else "earlier" if earlier else "at about the same time"
        out.append(
            f"They first reach the commanded {m.axis} rate {word} (median {_num(tf)} s against "
            f"{_num(ts)} s)" + (f"; {never}." if never else ".")
        )
    elif never:
        out.append(f"{never[:1].upper()}{never[1:]}.")
    if m.members:
        out.append(
            "The same driver shows in the significant factors "
            + ", ".join(m.members)
            + " (other views of the same quantity)."
        )
    return " ".join(out)


def mechanisms(res, max_families: int = MAX_FAMILIES) -> list[Mechanism]:
    """One :class:`Mechanism` per significant driver family of a
    :class:`~rcsim.analysis.results.drivers.pipeline.DriverResults`, strongest first."""
    d, rs = res.drivers, res.runset
    if d is None or not len(d):
        return []
    rows = d.set_index("factor")
    out = []
    for fam in families(d, rs.X)[:max_families]:
        lead = rows.loc[fam[0]]
        m = explain(
            fam[0],
            lead["failure_region"],
            rs.X[fam[0]].to_numpy(),
            rs.y,
            rs.runs,
            _threshold(rs),
            fail_share=lead.get("region_fail_share"),
            run_share=lead.get("region_run_share"),
            strata=rs.strata,
            manifest=rs.manifest,
        )
        m.members = fam[1:]
        m.text = _paragraph(m, _threshold(rs))
        out.append(m)
    return out


def strongest(res) -> str:
    """One sentence naming the strongest driver and its failure region (for a caption), with
    a space after it; "" when no input is significant."""
    d = res.drivers
    if d is None or not len(d) or not d["significant"].any():
        return ""
    row = d[d["significant"]].iloc[0]
    side, _ = _parse_region(row["failure_region"])
    unit = unit_of(row["factor"])
    where = (
        f"; failures concentrate at {row['failure_region']}{' ' + unit if unit else ''} "
        f"({_pct(row['region_fail_share'])} of failures in "
        f"{_pct(row.get('region_run_share', float('nan')))} of runs)"
        if side != "none"
        else ""
    )
    what = describe(row["factor"])
    return f"{what[:1].upper()}{what[1:]} ({row['factor']}) is the strongest driver{where}. "


def regions_caption(res, factors) -> str:
    """A sentence for the failure-region figure: each shown factor's side and share of
    failures ("" when none has a region); ends with a space when not empty."""
    rows = res.drivers.set_index("factor")
    said = []
    for f in factors:
        side, _ = _parse_region(rows.loc[f, "failure_region"])
        if side in ("high", "low"):
            said.append(f"{side} {f} ({_pct(rows.loc[f, 'region_fail_share'])} of failures)")
        elif side in ("middle", "several"):
            said.append(f"{f} in {rows.loc[f, 'failure_region']}")
    return f"Failures concentrate at {'; '.join(said)}. " if said else ""


def section(res) -> Section:
    """The report section: one paragraph per family (:func:`mechanisms`)."""
    mechs = mechanisms(res) if res.has_failures else []
    if not mechs:
        blocks = [text_block("No input is a significant driver: no mechanism to describe.")]
    else:
        blocks = [
            text_block(
                "What the runs show, one paragraph per significant driver family (a factor and "
                "the significant factors that are other views of it). Every number is counted "
                "from the runs: the failure region is the driver table's; 'corrective' firings "
                "are those after the commanded rate was first reached.",
                *[m.text for m in mechs],
            )
        ]
    return Section("How the runs fail", blocks, "mechanism")
