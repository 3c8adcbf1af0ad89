"""What a reader of a rare-event estimate is told, built only from its record's figures
(:func:`rcsim.analysis.apps.rare.estimate.result_record`; the tests rebuild each sentence from
them).

The closest failure is stated as what it is: the failure run nearest the nominal vehicle that
the estimation found, its distance in sigmas over the coordinates the spec disperses, an upper
bound on the most probable failure point's (in tens of dimensions a sample lies well beyond the
design point, ``docs/rare_events.md``), and its largest coordinates by name.
"""

from __future__ import annotations


def estimate_text(rec: dict) -> str:
    """The estimate, its interval and CoV, or the bound, in one phrase; for a case of several
    criteria, the series combination and each criterion's own figures; no figure at all when a
    criterion's region was not explored (the record's reason says which and what would resolve
    it)."""
    pct = f"{rec['confidence']:.0%}"
    if rec["status"] == "not_explored":
        return f"not estimated: {rec['reason']}"
    if rec["status"] == "not_resolved":
        text = (
            f"not resolved: no failure in {rec['runs']:,} runs, "
            f"P(fail) < {rec['upper_bound']:.3g} ({pct} one-sided bound"
            + (", the sum of the criteria's" if rec.get("criteria") else "")
            + ")"
        )
        return text + _criteria_text(rec)
    lo, hi = rec["interval"]
    cov = "" if rec["cov"] is None else f", CoV {rec['cov']:.2f}"
    text = f"P(fail) = {rec['probability']:.3g} ({pct} interval {lo:.3g} - {hi:.3g}{cov})"
    if rec["status"] == "monte_carlo":
        if rec["probability"] == 1.0:
            text += f": every one of the first {rec['runs']:,} runs failed (not a rare event)"
        else:
            text += ": not rare, plain Monte Carlo of the first level (exact interval)"
    elif rec["status"] == "budget":
        text += ": the budget ended before the failure level (few failure runs; a rough estimate)"
    elif rec["status"] == "partial":
        text += ": some criteria saw no failure, their bounds enter the upper end"
    return text + _criteria_text(rec)


def interval_text(rec: dict) -> str:
    """The interval or the bound alone, short (a table cell); ``none`` when nothing can be
    stated."""
    if rec["interval"] is not None:
        lo, hi = rec["interval"]
        return f"{lo:.2g} - {hi:.2g}"
    if rec["upper_bound"] is not None:
        return f"< {rec['upper_bound']:.2g} (one-sided)"
    return "none: " + ", ".join(rec.get("unexplored") or []) + " not explored"


def _criteria_text(rec: dict) -> str:
    """`` (series bounds over rate: ..., attitude: ...)`` for a case of several criteria."""
    crit = rec.get("criteria")
    if not crit:
        return ""
    pct = f"{rec['criterion_confidence']:.1%}"
    parts = []
    for name, c in crit.items():
        if c["status"] == "not_resolved":
            parts.append(f"{name} no failure, P < {c['upper_bound']:.3g}")
        else:
            lo, hi = c["interval"]
            parts.append(f"{name} P = {c['probability']:.3g} ({lo:.3g} - {hi:.3g})")
    return (
        f"; series-system bounds over {len(crit)} criteria, each estimated on its own margin "
        f"at {pct}: " + ", ".join(parts)
    )


def closest_text(rec: dict) -> str:
    """The closest failure found, in words; empty when none was found."""
    cf = rec.get("closest_failure")
    if not cf:
        return ""
    top = ", ".join(f"{name} {value:+.1f} sigma" for name, value in cf["largest"])
    return (
        f"closest failure found at {cf['sigma_active']:.2f} sigma from the nominal over the "
        f"dispersed inputs (an upper bound on the most probable failure point's distance): "
        f"{top}"
    )


def case_sentence(name: str, rec: dict) -> str:
    """One line per case: estimate, runs, plain Monte Carlo's runs for the same CoV, closest
    failure."""
    parts = [f"{name}: {estimate_text(rec)}", f"{rec['runs']:,} runs by {rec['method']}"]
    if rec["status"] == "converged" and rec.get("plain_mc_runs_same_cov"):
        parts[-1] += f" (plain Monte Carlo: {rec['plain_mc_runs_same_cov']:,.0f} for that CoV)"
    if rec["failures_found"]:
        parts.append(f"{rec['failures_found']:,} failure runs")
    close = closest_text(rec)
    if close:
        parts.append(close)
    return "; ".join(parts)
