"""The sentences of "How the runs fail", and the captions that name the strongest driver.

Every number a sentence states is one of :attr:`.mechanism.Mechanism.figures` (counted from the
runs table by :mod:`.mechanism`), written by :func:`~.probabilities.rate_text` (a rate with its
Clopper-Pearson interval), :func:`~.probabilities.share_text` (a count and its share) or
:func:`~.probabilities.pct` -- significant figures, never a non-zero rate shown as 0 % -- so a
test that counts the figures again from the runs finds them in the text.  What the sentences
say, and no more:

* a driver with a failure region: where it is, the failure rate inside against outside (with
  intervals) and the failures it holds; confined to some cases (:func:`.mechanism.confined_to`),
  counted within those cases and named with them, the other cases counted apart;
* a driver without one: no range of it alone reaches twice the base failure rate, and the
  scenario boxes and flagged interactions that bound it (a band or tail found jointly is
  described as such), or that none does -- never "spread over the whole range";
* the failing axis against the failed runs *outside* the region (a population that could
  differ: the successful runs are below the threshold on every axis by definition), the
  firings against the successful runs of the same cases.
"""

from __future__ import annotations

import numpy as np

from rcsim.analysis.results.drivers.findings import findings
from rcsim.analysis.results.drivers.mechanism import (
    MAX_FAMILIES,
    Mechanism,
    acts_elsewhere,
    case_region,
    confined_to,
    elsewhere_counts,
    explain,
    families,
    per_case_families,
    threshold_of,
)
from rcsim.analysis.results.drivers.probabilities import pct, rate_text, share_text
from rcsim.analysis.results.drivers.single import in_region, parse_region
from rcsim.analysis.results.report.html import Section, text_block

NBSP = "\u00a0"  # no line break between a number and its sign


def _p(k: int, n: int) -> str:
    return f"{pct(k / n) if n else '-'}{NBSP}%"


def _num(x: float) -> str:
    return f"{x:.3g}"


def _cases_words(cases: list) -> str:
    return cases[0] if len(cases) == 1 else ", ".join(cases[:-1]) + " and " + cases[-1]


def _named(m: Mechanism, capital: bool = False) -> str:
    """The driver in words and by name ("the moment of inertia about z (Izz) (izz_kg_m2)");
    by name alone when there are no other words for it (a column of a table file)."""
    if m.description == m.factor:
        return m.factor
    words = f"{m.description[:1].upper()}{m.description[1:]}" if capital else m.description
    return f"{words} ({m.factor})"


def _where(m: Mechanism) -> str:
    f, unit = m.figures, f" {m.unit}" if m.unit else ""
    of = "of runs"
    if m.scope:
        of = "of that case's runs" if len(m.scope) == 1 else "of these cases' runs"
    share = _p(f["region_runs"], f["runs"])
    return {
        "high": f"high (its top {share} {of}, {m.region}{unit})",
        "low": f"low (its bottom {share} {of}, {m.region}{unit})",
        "middle": f"in a middle band ({m.region.replace('..', 'to')}{unit}, {share} {of})",
        "several": f"in {m.region}{unit} ({share} {of})",
        "none": "",
    }[m.side]


def _region_sentences(m: Mechanism) -> list[str]:
    f = m.figures
    name = _named(m)
    out = []
    if m.scope:
        those = _cases_words(m.scope)
        out.append(
            f"{_named(m, capital=True)} is a flagged driver only within {those} "
            f"({len(m.scope)} of the {m.analysed_cases} cases analysed alone; family-wise over "
            "every case and input)."
        )
        where = f"In {'that case' if len(m.scope) == 1 else 'those cases'}, runs fail when "
        out.append(
            f"{where}it is {_where(m)}: {f['region_failed']:,} of the {f['region_runs']:,} "
            f"runs there failed, {rate_text(f['region_failed'], f['region_runs'])}, against "
            f"{rate_text(f['out_failed'], f['out_runs'])} of the other runs "
            f"({f['out_failed']:,} of {f['out_runs']:,}); the region holds "
            f"{share_text(f['region_failed'], f['failed'])} of "
            f"{'its' if len(m.scope) == 1 else 'their'} failures."
        )
        out.append(
            "In the other cases runs in the same range fail at "
            f"{rate_text(f['other_region_failed'], f['other_region_runs'])} against "
            f"{rate_text(f['other_out_failed'], f['other_out_runs'])} outside it."
        )
        return out
    out.append(
        f"Runs fail when {name} is {_where(m)}: {f['region_failed']:,} of the "
        f"{f['region_runs']:,} runs there failed, {rate_text(f['region_failed'], f['region_runs'])}"
        f", against {rate_text(f['out_failed'], f['out_runs'])} of the other runs "
        f"({f['out_failed']:,} of {f['out_runs']:,}); the region holds "
        f"{share_text(f['region_failed'], f['failed'])} of all failures."
    )
    out += _flagged_cases_sentence(m)
    cases = f.get("region_cases", [])
    if cases and f.get("region_case_count", 0) > 0:
        named = ", ".join(f"{c} ({k:,})" for c, k in cases)
        out.append(
            f"The region's failed runs come from {f['region_case_count']} "
            f"case{'s' if f['region_case_count'] > 1 else ''}"
            + (f", most from {named}." if f["region_case_count"] > 1 else f": {named}.")
        )
    return out


def _flagged_cases_sentence(m: Mechanism) -> list[str]:
    """For a driver flagged in some cases that acts in the others too (not confined)."""
    if not m.flagged_cases:
        return []
    f, n = m.figures, len(m.flagged_cases)
    head = (
        f"Per case it is a flagged driver in {_cases_words(m.flagged_cases)} ({n} of the "
        f"{m.analysed_cases} cases analysed alone), but it acts in the other cases too: "
    )
    shown = []
    if f.get("other_cases"):
        shown.append(
            f"in {f['other_cases_shown']} of the {f['other_cases']} other cases analysed alone it "
            "differs between failed and successful runs at p < 0.05 (uncorrected)"
        )
    if f.get("other_region_runs") and f.get("other_out_runs"):
        shown.append(
            "runs in this range fail at "
            f"{rate_text(f['other_region_failed'], f['other_region_runs'])} against "
            f"{rate_text(f['other_out_failed'], f['other_out_runs'])} outside it"
        )
    return [head + "; ".join(shown) + "; so it is described over all runs."]


def _axis_sentences(m: Mechanism) -> list[str]:
    f, a = m.figures, m.axis
    limit = f">= {m.threshold:g} deg/s" if m.threshold is not None else m.threshold_rule
    if a is None:
        axes = [x for x in ("roll", "pitch", "yaw") if f"off_{x}" in f]
        if not axes or not f["region_failed"]:
            return []
        return [
            "No one axis is off in most of these failed runs: "
            + ", ".join(f"{x} {share_text(f[f'off_{x}'], f['region_failed'])}" for x in axes)
            + f" end with |rate error| {limit} on that axis."
        ]
    k, n = f[f"off_{a}"], f["region_failed"]
    s = (
        f"It is the {a} rate that is off: {share_text(k, n)} of these failed runs end with "
        f"|{a} rate error| {limit}"
    )
    no = f["outside_failed"]
    if no:
        s += f", against {share_text(f[f'outside_off_{a}'], no)} of the failed runs outside it"
    others = [x for x in ("roll", "pitch", "yaw") if x != a and f"off_{x}" in f]
    if others:
        s += "; the other axes of these failed runs: " + ", ".join(
            f"{x} {_p(f[f'off_{x}'], n)}" for x in others
        )
    out = [s + "."]
    if m.table_firing:
        times = ", ".join(f"{t:.2f} s ({c})" for c, t in m.table_firing.items())
        out.append(
            f"In the cases with most of these failures the table flown ({m.table}) fires the "
            f"{a} jets for {times}."
        )
    return out


def _more(a: float, b: float, rel: float, absolute: float) -> str:
    """'more', 'fewer' or 'about as many' (a against b)."""
    if a - b >= max(absolute, rel * abs(b)):
        return "more"
    if b - a >= max(absolute, rel * abs(a)):
        return "fewer"
    return "about as many"


def _firing_sentences(m: Mechanism) -> list[str]:
    f, a = m.figures, m.axis
    out: list[str] = []
    if a is None:
        return out
    if "firings_failed" in f and np.isfinite(f["firings_failed"]):
        ff, fs = f["firings_failed"], f["firings_ok"]
        how = {"more": "more often than", "fewer": "less often than"}
        s = (
            f"These failed runs fire the {a} jets {_num(ff)} times on average, "
            f"{how.get(_more(ff, fs, 0.25, 0.5), 'about as often as')} the successful runs "
            f"of the same cases ({_num(fs)})"
        )
        if "late_failed" in f:
            lf, ls = f["late_failed"], f["late_ok"]
            s += (
                f"; {_num(lf)} of those firings come after the commanded rate was first "
                f"reached (successful runs: {_num(ls)})"
            )
            if _more(lf, ls, 0.25, 0.5) == "more":
                s += ", so late corrective firings follow"
        out.append(s + ".")
    never = ""
    if f.get("never_failed", 0) > 0:
        within = f"within {m.threshold:g} deg/s of" if m.threshold is not None else "to"
        never = (
            f"{share_text(f['never_failed'], f['region_failed'])} of them never come {within} "
            f"the commanded {a} rate"
            + (
                f" (failed runs outside the region: {_p(f['never_outside'], f['outside_failed'])})"
                if f["outside_failed"]
                else ""
            )
        )
    if "time_failed_s" in f:
        tf, ts = f["time_failed_s"], f["time_ok_s"]
        later = tf - ts >= max(0.2, 0.1 * abs(ts))
        earlier = ts - tf >= max(0.2, 0.1 * abs(tf))
        word = "later" if later else "earlier" if earlier else "at about the same time"
        out.append(
            f"They first reach the commanded {a} rate {word} (median {_num(tf)} s against "
            f"{_num(ts)} s for the successful runs of the same cases)"
            + (f"; {never}." if never else ".")
        )
    elif never:
        out.append(f"{never[:1].upper()}{never[1:]}.")
    return out


def paragraph(m: Mechanism) -> str:
    """The paragraph of one :class:`~.mechanism.Mechanism` (module docstring)."""
    if m.side == "none":
        base = rate_text(m.figures["failed"], m.figures["runs"])
        if m.scope:
            those = "that case's" if len(m.scope) == 1 else "those cases'"
            head = (
                f"{_named(m, capital=True)} is a flagged driver only within "
                f"{_cases_words(m.scope)} ({len(m.scope)} of the {m.analysed_cases} cases "
                "analysed alone; family-wise over every case and input), but no range of it "
                f"alone reaches twice {those} failure rate, {base}."
            )
        else:
            head = (
                f"{_named(m, capital=True)} is a flagged driver, but no range of it alone "
                f"reaches twice the base failure rate, {base}."
            )
        out = [
            head,
            *_flagged_cases_sentence(m),
            *(m.context or ["No scenario box and no flagged interaction bounds it."]),
        ]
    else:
        out = [*_region_sentences(m), *_axis_sentences(m), *_firing_sentences(m)]
    if m.members:
        out.append(
            "The same driver shows in the flagged factors "
            + ", ".join(m.members)
            + " (other views of the same quantity)."
        )
    return " ".join(out)


def joint_context(res, factor: str) -> list[str]:
    """Sentences on what bounds a driver without a 1-D region: the scenario boxes that restrict
    it (directly or through a ratio) and the flagged interactions that hold it."""
    out = []
    b = res.boxes
    if b is not None:
        for box in b.boxes:
            through = [d for d in box.dims if factor in b.ratio_parts.get(d, ())]
            if factor not in box.dims and not through:
                continue
            how = f"through the ratio {', '.join(through)}" if through else "directly"
            dim = through[0] if through else factor
            band = _band_words(b, box, dim)
            # Where the box's counts hold: outside the earlier boxes and in its cases only.
            where = []
            if box.number > 1:
                earlier = ", ".join(str(k) for k in range(1, box.number))
                where.append(
                    f"among the runs outside box{'es' if box.number > 2 else ''} {earlier}"
                )
            if b.case_names and not box.cats.all():
                kept = [c for c, k in zip(b.case_names, box.cats) if k]
                where.append(
                    f"in the {len(kept)} case{'s' if len(kept) > 1 else ''} it "
                    f"keeps ({', '.join(kept)})"
                )
            qualifier = f" {' and '.join(where)}" if where else ""
            text = (
                f"Its failures lie in {band} found by box {box.number}{qualifier} (it bounds "
                f"{factor} {how}): the box holds {share_text(box.failed, b.total_failed)} of "
                f"all failed runs in {_p(box.runs, b.total_runs)} of the runs, and a run in it "
                f"fails at {rate_text(box.failed, box.runs)}."
            )
            if where:  # the same band over every run, so the restriction is not dropped
                k, n = _band_counts(res, b, box, dim)
                text += (
                    f" Over all {res.runset.y.size:,} runs the same band of {dim} holds {n:,} "
                    f"runs, {rate_text(k, n)} of them failed."
                )
            out.append(text)
    pt = res.pair_table
    if pt is not None:
        hits = pt[pt["significant"] & ((pt["factor_a"] == factor) | (pt["factor_b"] == factor))]
        for _, r in hits.iterrows():
            other = r["factor_b"] if r["factor_a"] == factor else r["factor_a"]
            out.append(
                f"With {other} it is a flagged interaction (p = {r['p_interaction']:.2g}): "
                "within cases, the pair's failures are not the product of its two inputs' "
                "separate effects."
            )
    return out


def _limits_of(box, j: int) -> tuple[str, str]:
    """A box's limits on dimension ``j`` as printed (figures that reproduce its runs)."""
    if box.lo_text:
        return box.lo_text[j], box.hi_text[j]
    return f"{box.lo[j]:.4g}", f"{box.hi[j]:.4g}"


def _band_words(b, box, dim: str) -> str:
    """ "a band of X" (limited on both sides) or "a tail of X" (one side) for dimension ``dim``."""
    j = b.names.index(dim)
    lo, hi = np.isfinite(box.lo[j]), np.isfinite(box.hi[j])
    lo_t, hi_t = _limits_of(box, j)
    if lo and hi:
        return f"a band of {dim} ({lo_t} to {hi_t})"
    return f"a tail of {dim} ({dim} {'>=' if lo else '<='} {lo_t if lo else hi_t})"


def _band_counts(res, b, box, dim: str) -> tuple[int, int]:
    """``(failed, runs)`` of every run analysed inside the box's limits on ``dim`` alone."""
    X = res.runset.X
    if dim in b.ratio_parts:
        num, den = b.ratio_parts[dim]
        x = X[num].to_numpy(float) / X[den].to_numpy(float)
    else:
        x = X[dim].to_numpy(float)
    j = b.names.index(dim)
    inside = (x >= box.lo[j]) & (x <= box.hi[j])
    return int((inside & res.runset.y).sum()), int(inside.sum())


def mechanisms(res, max_families: int = MAX_FAMILIES) -> list[Mechanism]:
    """One :class:`~.mechanism.Mechanism` per flagged driver family of a
    :class:`~rcsim.analysis.results.drivers.pipeline.DriverResults`, strongest first (computed
    once and kept on ``res``)."""
    cached = getattr(res, "_mechanisms", None)
    if cached is not None:
        return cached
    d, rs = res.drivers, res.runset
    out: list[Mechanism] = []
    if d is not None and len(d):
        rows = d.set_index("factor")
        pooled = families(d, rs.X)
        for fam in (pooled + per_case_families(res, pooled))[:max_families]:
            scope, analysed = confined_to(res, fam)
            factor, region = fam[0], rows["failure_region"].get(fam[0], "")
            if scope:  # a driver of some cases: its region as their own fit has it
                factor, region = case_region(res, fam, scope) or (factor, region)
            m = _counted(res, factor, region, scope)
            counts = {}
            if scope:
                shown, others = elsewhere_counts(res, fam, scope)
                counts = {"other_cases_shown": shown, "other_cases": others}
                m.figures.update(counts)
            if acts_elsewhere(m):  # flagged in some cases, but not confined to them
                region = rows["failure_region"].get(fam[0], "")
                # The other cases' figures again, in the pooled region the paragraph states.
                scoped = _counted(res, fam[0], region, scope)
                m = _counted(res, fam[0], region, [])
                m.flagged_cases = scope
                m.figures.update(
                    {k: v for k, v in scoped.figures.items() if k.startswith("other_")}
                )
                m.figures.update(counts)
            m.analysed_cases = analysed
            m.members = [f for f in fam if f != m.factor]
            if m.side == "none":
                m.context = joint_context(res, m.factor)
            m.text = paragraph(m)
            out.append(m)
    res._mechanisms = out
    return out


def _counted(res, factor: str, region, scope: list) -> Mechanism:
    """The figures of ``factor`` over the runs of ``res`` (within ``scope`` when given)."""
    rs = res.runset
    return explain(
        factor,
        region,
        rs.X[factor].to_numpy(),
        rs.y,
        rs.runs,
        threshold_of(rs),
        strata=rs.strata,
        manifest=rs.manifest,
        scope=scope,
    )


def strongest(res) -> str:
    """One sentence naming the strongest driver and where failures concentrate (for a caption),
    with a space after it; "" when no input is flagged."""
    mechs = mechanisms(res) if res.has_failures else []
    if not mechs:
        return ""
    m = mechs[0]
    f = m.figures
    name = _named(m, capital=True)
    if m.side == "none":
        return f"{name} is the strongest driver; no range of it alone reaches twice the base rate. "
    scope = f" within {_cases_words(m.scope)}" if m.scope else ""
    unit = f" {m.unit}" if m.unit else ""
    return (
        f"{name} is the strongest driver{scope}; failures concentrate at {m.region}{unit} "
        f"({share_text(f['region_failed'], f['failed'])} of the failures in "
        f"{_p(f['region_runs'], f['runs'])} of the runs{scope}). "
    )


def regions_caption(res, factors) -> str:
    """A sentence for the failure-region figure: each shown factor's side and its failures in
    the region ("" when none has a region); ends with a space when not empty."""
    rows = res.drivers.set_index("factor")
    y = res.runset.y
    said = []
    scopes = {
        f: m.scope
        for m in (mechanisms(res) if res.has_failures else [])
        if m.scope
        for f in [m.factor, *m.members]
    }
    for f in factors:
        if not bool(rows.loc[f, "significant"]):  # an unflagged region is no place of failures
            continue
        region = rows.loc[f, "failure_region"]
        side, _ = parse_region(region)
        if side == "none":
            continue
        k, kf = int((in_region(res.runset.X[f].to_numpy(), region) & y).sum()), int(y.sum())
        count = f"{k:,} of {kf:,} failures, {pct(k / kf)} %"
        if f in scopes:  # pooled counts of a driver confined to some cases: say where it acts
            count += f"; it acts within {_cases_words(scopes[f])} only, How the runs fail"
        if side in ("high", "low"):
            said.append(f"{side} {f} ({count})")
        else:
            said.append(f"{f} in {region} ({count})")
    return f"Failures concentrate at {'; '.join(said)}. " if said else ""


def section(res) -> Section:
    """The report section: one paragraph per family (:func:`mechanisms`)."""
    mechs = mechanisms(res) if res.has_failures else []
    if not mechs:
        n_out = sum(f.family == "outcomes" for f in findings(res)) if res.has_failures else 0
        others = (
            f" The {n_out} outcome driver{'s' if n_out != 1 else ''} in the summary concern "
            "other outcomes (per axis, a second threshold, propellant, delta-v), not why runs "
            "fail the campaign's criterion; the Outcomes section lists them."
            if n_out
            else ""
        )
        blocks = [
            text_block(
                "No input is a flagged driver of the failures (pooled or in any case): no "
                "mechanism to describe." + others
            )
        ]
    else:
        blocks = [
            text_block(
                "What the runs show, one paragraph per flagged driver family (a factor and the "
                "flagged factors that are other views of it). Every number is counted from the "
                "runs: the failure region is the driver table's; rates carry their exact 95 % "
                "interval; 'corrective' firings are those after the commanded rate was first "
                "reached.",
                *[m.text for m in mechs],
            )
        ]
    return Section("How the runs fail", blocks, "mechanism")
