"""What the data say about how runs fail: the figures behind one paragraph per driver family.

The driver ranking says *which* inputs differ between failed and successful runs; this module
counts, for each flagged driver family, the figures a paragraph of "How the runs fail" states
(:mod:`.mechanism_text` writes the sentences), every one counted from the runs table and kept
by name in :attr:`Mechanism.figures` so that a test can count it again:

* **which input, which side, which cases** -- the family's leading factor, its failure region
  (the driver table's, in the input's units) read as its high side, low side or a middle band;
  the runs and failed runs inside and outside it.  A driver the per-case analysis flags in some
  of the cases analysed alone but not in the others is *confined* to those cases
  (:attr:`Mechanism.scope`) unless the other cases show it too, on evidence corrected for the
  two measures tried (:func:`acts_elsewhere`: then the other cases lacked the power to flag
  it, and it is described over all runs with the flagged cases named); confined, its
  figures are counted within those cases and the other cases' apart, with the failure region of
  its fit in the confined case with the most failures (:func:`case_region`), so that a driver
  of one case is never described as if it acted everywhere;
* **which axis fails** -- per axis, how many of the region's failed runs end with that axis's
  rate error at or past the failure threshold, against the failed runs outside the region (the
  successful runs are no contrast: below the threshold on every axis by definition);
* **how the firings differ** -- firing events on that axis's jets (``firings_{axis}``), those
  after the commanded rate was first reached (``firings_{axis} - firings_to_rate_{axis}``,
  "corrective" firings) and the time that rate was first reached (``time_to_rate_{axis}_s``),
  failed runs of the region against successful runs of the same cases.

A *family* is a flagged single driver together with the lower-ranked flagged drivers that are
another view of the same quantity: the same name up to the jet-group direction
(``authority_yaw_fire_rad_s2`` and ``authority_yaw_pos_rad_s2``) or a rank correlation of at
least :data:`FAMILY_CORRELATION` with it over the runs (a group's authority and the inertia it
divides by).  Columns are those of :mod:`rcsim.analysis.engine.runs_table`; a run table without
outcome columns gets the figures it can support and no more.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from rcsim.analysis.engine import runs_table
from rcsim.analysis.results.drivers.single import in_region, parse_region
from rcsim.lookup.table_edits import axis_cycles, jet_axes
from rcsim.models.errors import InputError
from rcsim.models.tables import PAPER_CYCLE_S, load_lookup_table

#: Two flagged factors whose Spearman correlation over the runs reaches this are one family.
FAMILY_CORRELATION = 0.5
#: Families described, strongest first.
MAX_FAMILIES = 4
#: Cases named where the region's failed runs come from.
TOP_CASES = 3
#: One-sided Fisher exact p-value at or below which a driver flagged in some cases still acts
#: in the others (its region fails more often there too): it is then not confined.
ELSEWHERE_P = 0.05
#: ... and runs in its region there fail at least this many times as often as the others.
ELSEWHERE_LIFT = 2.0

AXES = ("roll", "pitch", "yaw")
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
    """What the runs show about one driver family.

    Attributes
    ----------
    factor : str
        The family's leading (highest-ranked) flagged factor.
    description : str
        What it is, in words.
    side : {"high", "low", "middle", "several", "none"}
        Where its failure region lies in the factor's range.
    region : str
        The failure region as the driver table gives it (input units).
    unit : str
    scope : list of str
        The cases the driver is confined to (flagged per case there and not in the other cases
        analysed alone, and its region shows no excess of failures in those other cases);
        empty: it is described over all runs.
    flagged_cases : list of str
        The cases it is flagged in per case, when that is some but not all of the cases
        analysed alone and yet its region fails more often in the others too (so it is
        described over all runs, with these cases named).
    analysed_cases : int
        Cases analysed alone (the per-case family).
    figures : dict
        Every number the paragraph states, by name (counts are ints, means and medians floats):
        ``runs, failed`` (in scope), ``all_failed``, ``region_runs, region_failed, out_runs,
        out_failed``; confined: ``other_region_runs, other_region_failed, other_out_runs,
        other_out_failed`` and ``other_cases_shown`` of ``other_cases``
        (:func:`elsewhere_counts`); ``region_cases`` (case, failed runs in the region) most
        first and ``region_case_count``; per axis ``off_<axis>`` (the region's failed runs off
        on it) and ``outside_off_<axis>`` (failed runs outside the region off on it),
        ``outside_failed``;
        firings ``firings_failed, firings_ok, late_failed, late_ok, never_failed,
        never_outside, time_failed_s, time_ok_s`` where the columns exist.
    axis : str or None
        The axis off in more than half of the region's failed runs (None: no one axis is).
    table_firing : dict
        The lookup table's firing time on ``axis`` [s] in the cases the region's failed runs
        come from (most failures first), when the campaign flew a lookup table.
    table : str
        That table's name.
    members : list of str
        The family's other flagged factors.
    context : list of str
        For a driver without a region: sentences on the boxes and interactions that bound it
        (:mod:`.mechanism_text`).
    threshold : float or None
        The rate-error failure threshold [deg/s] (None: unknown, the axis test is then the
        successful runs' 95th percentile, ``threshold_rule``).
    text : str
        The paragraph.
    """

    factor: str
    description: str
    side: str
    region: str
    unit: str
    scope: list = field(default_factory=list)
    flagged_cases: list = field(default_factory=list)
    analysed_cases: int = 0
    figures: dict = field(default_factory=dict)
    axis: str | None = None
    table_firing: dict = field(default_factory=dict)
    table: str = ""
    members: list = field(default_factory=list)
    context: list = field(default_factory=list)
    threshold: float | None = None
    threshold_rule: str = ""
    text: str = ""

    @property
    def fail_share(self) -> float:
        """Share of the scope's failed runs inside the region."""
        return self.figures["region_failed"] / max(self.figures["failed"], 1)

    @property
    def run_share(self) -> float:
        """Share of the scope's runs inside the region."""
        return self.figures["region_runs"] / max(self.figures["runs"], 1)


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
    if m and m.group(2) in AXES:
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


def family_key(factor: str) -> str:
    """A factor's name without its jet-group direction (one family across directions)."""
    return re.sub(r"_(pos|neg|fire)(?=_|$)", "", factor)


def families(drivers: pd.DataFrame, X: pd.DataFrame) -> list[list[str]]:
    """The flagged factors grouped into families, strongest family first; each family's leader
    first (see the module docstring)."""
    sig = [f for f in drivers.loc[drivers["significant"].astype(bool), "factor"] if f in X]
    out: list[list[str]] = []
    for f in sig:
        for fam in out:
            lead = fam[0]
            same = family_key(f) == family_key(lead)
            if same or abs(X[f].corr(X[lead], method="spearman")) >= FAMILY_CORRELATION:
                fam.append(f)
                break
        else:
            out.append([f])
    return out


def per_case_families(res, pooled: list[list[str]]) -> list[list[str]]:
    """The factors flagged only per case -- in no pooled family, by name or up to the jet-group
    direction -- as families of their own, best per-case p-value first.  A driver of one case is
    often too diluted by the other cases for the pooled test; it is a finding all the same and
    gets its paragraph (described within its cases, :func:`confined_to`)."""
    known = {f for fam in pooled for f in fam}
    keys = {family_key(f) for f in known}
    best: dict[str, float] = {}
    for c in res.cases:
        if c.singles is None or c.significant is None:
            continue
        names = [str(n) for n in c.singles.feature_names_in_]
        for j in np.flatnonzero(c.significant):
            n = names[j]
            if n in known or family_key(n) in keys or n not in res.runset.X:
                continue
            best[n] = min(best.get(n, np.inf), float(c.p_family[j]))
    out: list[list[str]] = []
    for n in sorted(best, key=lambda n: (best[n], n)):
        fam = next((f for f in out if family_key(f[0]) == family_key(n)), None)
        if fam is None:
            out.append([n])
        else:
            fam.append(n)
    return out


def explain(
    factor: str,
    region: str,
    x: np.ndarray,
    y: np.ndarray,
    runs: pd.DataFrame,
    threshold: float | None = None,
    strata: np.ndarray | None = None,
    manifest: dict | None = None,
    scope: list | None = None,
) -> Mechanism:
    """The figures of one factor: region, cases, failing axis and firings (module docstring).

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
    strata : ndarray (n,), optional
        Case of every run: failed runs are compared with the successful runs of the cases they
        fail in, and the region's failed runs are counted per case.
    manifest : dict, optional
        The campaign's manifest: with a lookup-table controller, the table's firing time on
        the failing axis in the failed runs' cases is stated.
    scope : list of str, optional
        The cases the driver is confined to (counted within them; the others apart).
    """
    x, y = np.asarray(x, float), np.asarray(y, bool)
    side, _ = parse_region(region)
    mech = Mechanism(
        factor=factor,
        description=describe(factor),
        side=side,
        region=region if isinstance(region, str) else "",
        unit=unit_of(factor),
        scope=list(scope or []),
        threshold=threshold,
    )
    inside = in_region(x, region)
    cases = None if strata is None else np.asarray(strata).astype(str)
    within = np.ones(y.size, bool)
    if mech.scope and cases is not None:
        within = np.isin(cases, mech.scope)
    fig = mech.figures
    fig["all_failed"] = int(y.sum())
    fig.update(_counts(inside, y, within, ""))
    if mech.scope:
        fig.update(_counts(inside, y, ~within, "other_"))
    focus = y & inside & within
    if cases is not None:
        names, counts = np.unique(cases[focus], return_counts=True)
        order = np.argsort(-counts, kind="stable")
        fig["region_cases"] = [(str(names[i]), int(counts[i])) for i in order[:TOP_CASES]]
        fig["region_case_count"] = int(names.size)
    if side == "none" or not focus.any():
        return mech
    outside = y & ~inside & within
    ok = ~y & within
    if cases is not None:
        same = ok & np.isin(cases, np.unique(cases[focus]))
        ok = same if same.any() else ok
    runs = runs.reset_index(drop=True)
    _axis(mech, runs, focus, outside, ok)
    _firings(mech, runs, focus, outside, ok)
    if cases is not None:
        _table_firing(mech, manifest, [c for c, _ in fig.get("region_cases", [])])
    return mech


def _counts(inside, y, rows, prefix: str) -> dict:
    """Runs and failed runs of ``rows``, inside and outside the region."""
    return {
        f"{prefix}runs": int(rows.sum()),
        f"{prefix}failed": int((y & rows).sum()),
        f"{prefix}region_runs": int((inside & rows).sum()),
        f"{prefix}region_failed": int((inside & rows & y).sum()),
        f"{prefix}out_runs": int((~inside & rows).sum()),
        f"{prefix}out_failed": int((~inside & rows & y).sum()),
    }


def axis_off(runs: pd.DataFrame, axis: str, threshold: float | None, ok: np.ndarray):
    """Runs whose final rate error on ``axis`` is off: ``|error| >= threshold``, or without a
    threshold above the 95th percentile of the runs ``ok`` (None: no such column)."""
    col = f"final_rate_err_{axis}_deg_s"
    if col not in runs:
        return None
    err = np.abs(runs[col].to_numpy(float))
    if threshold is not None:
        return err >= threshold
    return err > np.nanquantile(err[ok], 0.95)


def _axis(mech: Mechanism, runs, focus, outside, ok) -> None:
    fig = mech.figures
    fig["outside_failed"] = int(outside.sum())
    for axis in AXES:
        off = axis_off(runs, axis, mech.threshold, ok)
        if off is None:
            continue
        fig[f"off_{axis}"] = int((off & focus).sum())
        fig[f"outside_off_{axis}"] = int((off & outside).sum())
    if mech.threshold is None:
        mech.threshold_rule = "above the successful runs' 95th percentile"
    offs = {a: fig[f"off_{a}"] for a in AXES if f"off_{a}" in fig}
    # "It is the yaw rate that is off" only when that axis is off in most of these failures.
    if offs and 2 * max(offs.values()) > int(focus.sum()):
        mech.axis = max(offs, key=lambda a: offs[a])


def _firings(mech: Mechanism, runs, focus, outside, ok) -> None:
    a, fig = mech.axis, mech.figures
    if a is None or not ok.any():
        return
    fire, to_rate, t = f"firings_{a}", f"firings_to_rate_{a}", f"time_to_rate_{a}_s"
    if fire in runs:
        f = runs[fire].to_numpy(float)
        fig["firings_failed"], fig["firings_ok"] = _mean(f[focus]), _mean(f[ok])
        if to_rate in runs:
            late = f - runs[to_rate].to_numpy(float)
            fig["late_failed"], fig["late_ok"] = _mean(late[focus]), _mean(late[ok])
    if t in runs:
        tt = runs[t].to_numpy(float)
        fig["never_failed"] = int(np.isnan(tt[focus]).sum())
        fig["never_outside"] = int(np.isnan(tt[outside]).sum())
        if np.isfinite(tt[focus]).any() and np.isfinite(tt[ok]).any():
            fig["time_failed_s"] = float(np.nanmedian(tt[focus]))
            fig["time_ok_s"] = float(np.nanmedian(tt[ok]))


def _mean(v: np.ndarray) -> float:
    return float(np.nanmean(v)) if np.isfinite(v).any() else float("nan")


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
    a = AXES.index(mech.axis)
    for case in cases:
        kind, _, num = str(case).partition("-")
        if kind == "rate" and num.isdigit() and int(num) in table.case:
            row = int(np.flatnonzero(table.case == int(num))[0])
            mech.table_firing[str(case)] = float(cycles[row, a] * cycle_s)
    mech.table = str(ctrl["table"]).replace("\\", "/").split("/")[-1]


def threshold_of(runset) -> float | None:
    """The campaign's rate-error threshold [deg/s] from its manifest (None: unknown)."""
    t = (runset.manifest or {}).get("thresholds", {}).get("rate_error_deg_s")
    return None if t is None else float(t)


def confined_to(res, family: list) -> tuple[list, int]:
    """``(cases, analysed)``: the cases where the per-case family flags a factor of ``family``
    (by name or by name up to the jet-group direction: within one case a firing-direction
    factor duplicates a pos/neg one and only one is kept), when that is *some but not all* of
    the ``analysed`` cases; ``([], analysed)`` otherwise (the driver is described over all
    runs)."""
    keys = {family_key(f) for f in family}
    analysed = [c for c in res.cases if c.singles is not None and c.significant is not None]
    flagged = []
    for c in analysed:
        names = np.asarray(c.singles.feature_names_in_)[c.significant]
        if any(n in family or family_key(str(n)) in keys for n in names):
            flagged.append(str(c.case))
    if flagged and len(flagged) < len(analysed):
        return flagged, len(analysed)
    return [], len(analysed)


def case_region(res, family: list, scope: list) -> tuple[str, str] | None:
    """``(factor, region)`` of a confined driver: of the cases in ``scope``, the one with the
    most failures, its flagged factor of ``family`` (best p-value first) and that factor's
    failure region in the case's own fit (in the input's units).  A driver of one case has no
    pooled region when the other cases dilute it: its case's region is the one to state.  None
    when that case's fit has no region for it."""
    keys = {family_key(f) for f in family}
    cases = [
        c
        for c in res.cases
        if str(c.case) in scope and c.singles is not None and c.significant is not None
    ]
    for c in sorted(cases, key=lambda c: -c.failed):
        names = list(c.singles.feature_names_in_)
        hits = [
            j
            for j in np.flatnonzero(c.significant)
            if names[j] in family or family_key(names[j]) in keys
        ]
        for j in sorted(hits, key=lambda j: c.p_family[j]):
            if c.singles.regions_[j]:
                return str(names[j]), str(c.singles.regions_[j])
        return None
    return None


def elsewhere_counts(res, family: list, scope: list) -> tuple[int, int]:
    """``(k, n)``: of the ``n`` cases analysed alone outside ``scope`` that hold the family's
    leading factor (or its view up to the jet-group direction), the ``k`` where it differs
    between failed and successful runs at an uncorrected per-case p < :data:`ELSEWHERE_P`."""
    lead, key = family[0], family_key(family[0])
    k = n = 0
    for c in res.cases:
        if c.singles is None or str(c.case) in scope:
            continue
        names = [str(x) for x in c.singles.feature_names_in_]
        j = names.index(lead) if lead in names else None
        if j is None:
            j = next((i for i, x in enumerate(names) if family_key(x) == key), None)
        if j is None:
            continue
        n += 1
        k += int(c.singles.p_raw_[j] < ELSEWHERE_P)
    return k, n


def acts_elsewhere(m: Mechanism) -> bool:
    """Whether a confined mechanism acts in the cases outside its scope too, by either
    measure, each at half of :data:`ELSEWHERE_P` (Bonferroni over the two): its region's runs
    there fail at least :data:`ELSEWHERE_LIFT` times as often as the others and significantly so
    (one-sided Fisher exact test; both, because with tens of thousands of runs a small chance
    excess is significant where the input does nothing); or,
    per case, more of those cases show it at p < 0.05 (uncorrected) than chance would
    (Binomial(n, 0.05) upper tail at most half of :data:`ELSEWHERE_P`: a band of a ratio has no
    1-D region to count in), unless its region fails no more often inside than outside there.
    One other case showing it is never enough (its binomial tail is 0.05).  Either way the
    paragraph states the counts."""
    from scipy.stats import binom, fisher_exact

    f = m.figures
    if not m.scope:
        return False
    # Two measures, one conclusion: each is held at half of ELSEWHERE_P (Bonferroni), so that
    # spreading a case's mechanism over all runs needs evidence corrected for trying both.
    level = ELSEWHERE_P / 2
    has_region = f.get("other_region_runs", 0) > 0 and f.get("other_out_runs", 0) > 0
    k_in, n_in = f.get("other_region_failed", 0), f.get("other_region_runs", 0)
    k_out, n_out = f.get("other_out_failed", 0), f.get("other_out_runs", 0)
    k, n = f.get("other_cases_shown", 0), f.get("other_cases", 0)
    # The per-case count speaks for a driver without a 1-D region (a ratio's band); with a
    # region, its own counts elsewhere must not say the opposite (no excess inside it).
    contradicted = has_region and k_in * n_out <= k_out * n_in
    if n and k and not contradicted and binom.sf(k - 1, n, ELSEWHERE_P) <= level:
        return True
    if not has_region or k_in * n_out < ELSEWHERE_LIFT * k_out * n_in:
        return False
    table = [[k_in, n_in - k_in], [k_out, n_out - k_out]]
    return bool(fisher_exact(table, alternative="greater")[1] <= level)
