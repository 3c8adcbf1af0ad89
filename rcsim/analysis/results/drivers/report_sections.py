"""Report sections of the failure-driver analysis; each returns a :class:`Section`.

They read a :class:`rcsim.analysis.results.drivers.pipeline.DriverResults`; a later analysis builds
its own
sections and passes the list to :func:`rcsim.analysis.results.report.html.build_report` with these.
"""

from __future__ import annotations

import shlex

import numpy as np
import pandas as pd

from rcsim.analysis.engine import runs_table
from rcsim.analysis.results.drivers import figures, findings, report_boxes
from rcsim.analysis.results.drivers import mechanism_text as mechanism
from rcsim.analysis.results.drivers import report_outcomes as probs
from rcsim.analysis.results.drivers.conclusions import conclude
from rcsim.analysis.results.drivers.probabilities import share_text
from rcsim.analysis.results.report.html import (
    Section,
    figure_block,
    png_bytes,
    table_block,
    text_block,
)

_PAIR_COLS = [
    "rank",
    "factor_a",
    "factor_b",
    "kind",
    "score",
    "p_value",
    "p_joint",
    "gain",
    "stability",
]


def _present(df, cols):
    return df[[c for c in cols if c in df.columns]]


def summary(res) -> Section:
    """What was analysed: source, campaign spec, counts, failures per case."""
    rs = res.runset
    blocks = []
    n, nf = int(rs.y.size), int(rs.y.sum())
    counts = [("runs", n), ("failed runs", share_text(nf, n))]
    if getattr(rs, "subsampled", False):  # say how many were analysed out of how many
        N, NF = int(rs.total_runs), int(rs.total_failed)
        counts = [
            ("runs", f"{n:,} analysed of {N:,} (a seeded uniform subsample; Notes)"),
            (
                "failed runs",
                f"{share_text(nf, n)} of those analysed; {share_text(NF, N)} of all",
            ),
        ]
    facts = [
        ("source", f"{rs.kind} {rs.source.name}"),
        *counts,
        *probs.overall_facts(res),
        ("outcome column", rs.outcome),
        (
            "inputs analysed",
            f"{len(rs.raw_inputs)} recorded + {len(rs.derived_inputs)} physics-aware derived",
        ),
        *[
            (
                f"runs without {c}",
                f"{k:,} of {n:,}: none left out; {why}",
            )
            for c, (k, why) in getattr(rs, "placed", {}).items()
            if c in rs.X.columns
        ],
    ]
    m = rs.manifest
    if m:
        spec = m.get("spec", {})
        ctrl = spec.get("controller", {})
        disp = spec.get("dispersions", {})
        facts += [
            ("controller", _controller_text(ctrl)),
            *_vehicle_facts(m),
            (
                "dispersions",
                f"{m.get('dispersions_source') or runs_table.dispersions_source(spec)}, "
                f"scale {disp.get('scale', '?')}",
            ),
            ("seed / runs per case", f"{spec.get('seed', '?')} / {spec.get('runs_per_case', '?')}"),
            ("failure criterion", _criterion(m)),
            ("code version", ", ".join(f"{k} {v}" for k, v in m.get("code_version", {}).items())),
        ]
    blocks.append(table_block(pd.DataFrame(facts, columns=["", "value"]), "Campaign"))
    later: list[str] = []
    if res.has_failures:
        now, later = _findings_blocks(res)
        blocks += now
    cases = pd.DataFrame(
        [
            {
                "case": c.case,
                "runs": c.runs,
                "failed": c.failed,
                "failed_pct": 100.0 * c.failed / max(c.runs, 1),
                "share_of_all_failures": c.failed / max(nf, 1),
            }
            for c in res.cases
        ]
    )
    cases = probs.with_case_columns(cases, res)
    if len(res.cases) > 1:
        blocks.append(
            figure_block(
                figures.report_pngs(res)["failures_per_case.png"],
                "Failed runs per case, as a share of the case's runs; whiskers: the exact "
                "(Clopper-Pearson) 95 % interval of the case's failure probability.",
            )
        )
        carry = cases.sort_values("failed", ascending=False, kind="stable")
        carry = carry[carry["failed"] > 0]
        if len(carry):
            blocks.append(text_block(_most_failures_text(carry, len(cases), nf)))
        blocks.append(table_block(cases, "Failures per case", max_rows=60))
    return Section("Summary", blocks + later, "summary")


def _most_failures_text(carry: pd.DataFrame, n_cases: int, nf: int, most: int = 5) -> str:
    """Which cases carry the failures: the (at most ``most``) cases with the most, never a
    choice among ties -- cases tied at the cut are counted as a tie, not picked from."""
    head = f"{len(carry)} of {n_cases} cases have failures"
    failed = carry["failed"].astype(int)
    cut = int(failed.iloc[min(most, len(carry)) - 1])
    above, tied = carry[failed > cut], carry[failed == cut]
    if len(above) + len(tied) <= most:
        top = carry.head(most)
        return (
            f"{head}; the {len(top)} with the most ({', '.join(top['case'])}) carry "
            f"{share_text(int(top['failed'].sum()), nf)} of all failures."
        )
    each = f"{cut} failure{'s' if cut != 1 else ''} each"
    if not len(above):
        return f"{head}; all {len(tied)} tie at {each}, none carries more than another."
    return (
        f"{head}; the {len(above)} with the most ({', '.join(above['case'])}) carry "
        f"{share_text(int(above['failed'].sum()), nf)} of all failures; {len(tied)} more "
        f"tie at {each}."
    )


def _findings_blocks(res) -> tuple[list[str], list[str]]:
    """Every flag the report shows (the same as findings.csv and the CLI's): the head line and
    the findings on the failures, then apart the outcome drivers, which the summary puts after
    the failures per case so that many of them cannot bury the failure analysis."""
    c = conclude(res)
    found = c.findings
    blocks = [
        text_block(
            f"{c.summary_sentences()[0]} Every flag below is counted against one "
            "budget for the whole report (How to read this report); nothing else in the report "
            "is a finding."
        )
    ]
    later: list[str] = []
    if found:
        frame = findings.findings_frame(found)
        frame.insert(0, "what", frame["family"].map(findings.FAMILY_WORDS))
        on_failures = frame["family"].isin(findings.FAILURE_FAMILIES)
        shown = ["what", "finding", "p_value", "level"]
        if on_failures.any():
            blocks.append(
                table_block(
                    frame.loc[on_failures, shown], "Findings on the failures (findings.csv)", 40
                )
            )
        if (~on_failures).any():
            later.append(
                table_block(
                    frame.loc[~on_failures, shown],
                    "Outcome drivers: per axis, second threshold, propellant and delta-v "
                    "(findings.csv; the Outcomes section)",
                    max_rows=40,
                )
            )
    return blocks, later


def _controller_text(ctrl: dict) -> str:
    """The controller and, for a table controller, its table (a spec resolves ``table`` to
    "default" for every controller; only lookup and adaptive fly one)."""
    name, table = ctrl.get("name", "?"), ctrl.get("table")
    if name not in ("lookup", "adaptive") or not table:
        return str(name)
    if table == "default":
        return f"{name}, the packaged default table"
    return f"{name}, table {str(table).split('/')[-1]}"


def _vehicle_facts(m: dict) -> list[tuple[str, str]]:
    """The vehicle file a campaign flew: its name, file and SHA-256 (none: the packaged
    vehicle).  The name is the manifest's (``vehicle_name``); a campaign written before it
    was recorded gets it from the file when that is still the one flown (same SHA-256)."""
    spec = m.get("spec", {})
    file, digest = spec.get("vehicle"), spec.get("vehicle_sha256")
    if not file:
        return [("vehicle", "the packaged vehicle (Gambone's, rcsim/models/vehicle/paper.toml)")]
    name = m.get("vehicle_name")
    if name is None:
        import hashlib

        from rcsim.models.errors import InputError
        from rcsim.spacecraft.vehicle import load_vehicle, resolve_vehicle

        try:
            if hashlib.sha256(resolve_vehicle(file).read_bytes()).hexdigest() == digest:
                name = load_vehicle(file).name
        except (InputError, OSError):
            name = None
    label = f"{name!r}, " if name else ""
    return [("vehicle", f"{label}file {file}, sha256 {digest}")]


def _criterion(m) -> str:
    t = m.get("thresholds", {})
    if t.get("rate_error_deg_s") is None:
        return "see the spec"
    text = runs_table.criterion_text(
        float(t["rate_error_deg_s"]),
        t.get("attitude_error_deg"),
        vehicle_file=bool(m.get("spec", {}).get("vehicle")),
        budgets=t,
    )
    # Where the thresholds came from (a manifest since vehicle files carry [failure]): the
    # paper's 0.04 deg/s judging another vehicle is said, not left to be assumed.
    return f"{text} ({t['source']})" if t.get("source") else text


def _imbalance_text(res) -> str:
    """What imbalance_* is, or why there is none (factors.py: pairs only)."""
    if any(f.startswith("imbalance_") for f in res.runset.derived_inputs):
        return (
            "imbalance_* (a group of exactly two jets, the paper's pairs, only) the thrust of "
            "the pair's first jet minus its second, what the other axes feel when it fires; "
        )
    return (
        "no imbalance_* factor: none of the vehicle's jet groups is a pair (a larger group's "
        "jets do not fire as one set, so no difference of two of them means anything); "
    )


def _physics_text(res) -> list[str]:
    """The physics-aware factors explained, only when some were derived (a table with no
    vehicle has none, and a paragraph on them would describe inputs the report does not hold)."""
    derived = res.runset.derived_inputs
    if not derived:
        return []
    out = []
    if any(not f.startswith("mode_") for f in derived):
        out.append(
            "Physics-aware factors: authority_<axis>_<pos|neg|fire>_rad_s2 is the angular "
            "acceleration the jet group gives (torque about the dispersed CG over the inertia); "
            "thrust_* the group's total thrust; "
            + _imbalance_text(res)
            + "pointing_loss_* the share of torque lost to jet misalignment; 'fire' is the "
            "group firing toward each case's commanded rate."
        )
    if any(f.startswith("mode_") and f.endswith("_freq_ratio") for f in derived):
        out.append(
            "mode_<name>_freq_ratio is the mode's coupled frequency (on the run's hub, "
            "mode_<name>_coupled_freq_hz) over the controller's firing frequency in that run: "
            "the firing events per second of its busiest axis (firings_<axis> over the flown "
            "duration; a pair starting together is one event). Near 1 (or a small integer) the "
            "jets' limit cycle drives the mode at resonance. The firing frequency is an outcome "
            "of the run, so a failure can move it too: read it as a mechanism to check, not a "
            "cause by itself."
        )
    return out


def method(res) -> Section:
    st = res.settings
    bw = res.singles.bandwidth_ if res.singles is not None else float("nan")
    return Section(
        "How to read this report",
        [
            text_block(
                "Each input is compared between failed and successful runs on its rank scale "
                "(units and skew do not matter). The densities of both groups are kernel estimates "
                f"(Gaussian kernel, bandwidth {bw:.3f} on the 0-1 rank scale: half Scott's "
                f"rule for "
                "the smaller group). The score is the total-variation distance between the two "
                "densities (0: the same, 1: no overlap) minus the distance expected with no effect "
                "at all (measured by shuffling the failure labels within each case).",
                f"p-values come from {st.n_permutations} label shuffles ({st.pair_b} for the "
                "pairs' joint test) and are corrected for the number of inputs by the max-T "
                "method (per case: over every case and input; outcomes: over every outcome and "
                f"input). The smallest reachable p is 1/{st.n_permutations + 1} (pairs' joint "
                f"test: 1/{st.pair_b + 1}).",
                findings.method_text(res),
                "The failure region of an input is where the failure probability is at least twice "
                "the base rate; 'region_fail_share' is the share of all failed runs inside it, "
                "'P(fail in region)' the share of the runs inside it that fail. "
                "'stability' is the share of random half-campaigns in which the factor ranks at "
                "least as high as here. A pair is an interaction (kind 'interaction') only "
                "when it adds to its two inputs' separate effects within the same runs of the "
                "same case: no-interaction (additive log-odds) is tested per case on "
                "median-split cells (Zelen's exact conditional test, exact p-values), "
                "Holm-adjusted over all pairs (p_value), and its joint test holds too "
                "(p_joint: the pair's own permutation test, max-T over all pairs, which only "
                "says the pair differs at all). 'gain' of a pair is its score beyond its better "
                "input. 'forest_rank' is a random forest's ranking of the same inputs, for "
                "comparison (another method family; not a test).",
                *_physics_text(res),
                "Failure probabilities (overall, per case, per failure region, per outcome) are "
                "shares of runs; each carries the Clopper-Pearson exact 95 % interval (its "
                "coverage is at least 95 % for every true probability). 'runs to bound' answers "
                f"how many runs, at the failure rate observed, make the one-sided exact 95 % "
                f"upper bound fall below {100 * st.bound_p:g} % (--bound-p); with no failure "
                "that is the rule of three, about 3 / P. 'not at this rate' means the observed "
                "rate is already at or above that probability.",
            )
        ],
        "method",
    )


def drivers(res, top: int = 25) -> Section:
    d = res.drivers
    blocks = [
        figure_block(
            figures.report_pngs(res)["ranking.png"],
            conclude(res).strongest
            + "Top inputs by score. Labels give the corrected p-value and the share "
            "of half-campaigns keeping the rank.",
        )
    ]
    sig = d[d["significant"]]
    level = res.levels.get("singles", res.settings.alpha)
    blocks.append(
        text_block(
            f"{len(sig)} of {len(d)} inputs are flagged single drivers (p < {100 * level:.3g} %, "
            "their family's share of the report's budget)"
            + (
                f": {', '.join(sig['factor'].head(12))}"
                + (f" and {len(sig) - 12} more (drivers.csv)." if len(sig) > 12 else ".")
                if len(sig)
                else "."
            )
        )
    )
    # Only flagged drivers get a failure-region panel: an unflagged input's smoothed P(fail | x)
    # rises above twice the base rate somewhere by chance (most often with few failures), and a
    # shaded "failure region" beside it would read as a finding.
    show = list(sig["factor"].head(4))
    if not show:
        blocks.append(
            text_block(
                "No failure region is drawn: no input is a flagged single driver, and where an "
                "unflagged input's smoothed failure probability passes twice the base rate is "
                "chance at this budget, not where failures are."
            )
        )
    else:
        blocks.append(
            figure_block(
                png_bytes(figures.failure_regions(res.singles, res.runset.X, show)),
                mechanism.regions_caption(res, show)
                + "Failure probability against the value of the leading inputs (smoothed); the "
                "shaded part is the failure region (at least twice the base rate, dashed).",
            )
        )
    # A failure region is a claim about where an input makes runs fail: the ranking shows it
    # only for the flagged drivers (drivers.csv keeps every input's).
    blocks.append(
        table_block(
            conclude(res).ranking_frame(),
            "Driver ranking (drivers.csv; failure regions of the flagged drivers only)",
            max_rows=top,
        )
    )
    return Section("Driver ranking", blocks, "drivers")


def pairs(res, top: int = 15) -> Section:
    if res.pair_table is None:
        return Section("Pairs", [text_block("Only one input: no pairs.")], "pairs")
    pt = res.pair_table
    blocks = [
        table_block(
            _present(pt, _PAIR_COLS),
            "Pairs: interactions, then other pairs by score (pairs.csv)",
            top,
        )
    ]
    gain = pt[pt["significant"]].sort_values("gain", ascending=False).head(5)
    if len(gain):
        blocks.append(
            table_block(
                _present(gain, _PAIR_COLS),
                "Interactions (exact test, Holm over all pairs, joint test holding), largest "
                "gain over their better input first",
            )
        )
    if res.unmapped_cases:
        blocks.append(
            text_block(
                "No map for "
                + ", ".join(
                    f"case {c} ({n} failed run{'s' if n != 1 else ''})"
                    for c, n in res.unmapped_cases
                )
                + ": no flagged driver in this case (family-wise over every case and "
                "input), so a map would show noise."
            )
        )
    # Why each map was drawn, as the conclusions say it (the loop's report says the same).
    reasons = [why for _, why in conclude(res).maps] or [""] * len(res.maps)
    for (case, fmap), name, why in zip(res.maps, figures.map_png_names(res), reasons):
        title = figures.map_title(case)
        blocks.append(
            figure_block(
                figures.report_pngs(res)[name],
                f"{title}: {fmap.feature_names_in_[0]} against {fmap.feature_names_in_[1]}"
                + (f" ({why})" if why else "")
                + ". "
                "Shading: failure probability of the k nearest runs (k by cross-validation); "
                "blank cells hold no runs. Red dots failed, blue succeeded (as Gambone Fig. 15). "
                "Right: the uncertainty of the shading.",
            )
        )
    return Section("Pairs and failure maps", blocks, "pairs")


def cases(res) -> Section:
    rows = []
    nf = max(int(res.runset.y.sum()), 1)
    level = res.levels.get("per_case", res.settings.alpha)
    for c in res.cases:
        row = {
            "case": c.case,
            "runs": c.runs,
            "failed": c.failed,
            "share_of_all_failures": c.failed / nf,
        }
        if c.singles is not None and c.significant is not None:
            flagged = np.flatnonzero(c.significant)
            flagged = flagged[np.argsort(c.singles.rank_[flagged], kind="stable")]
            for k in range(3):
                row[f"driver_{k + 1}"] = (
                    f"{c.singles.feature_names_in_[flagged[k]]} (p={c.p_family[flagged[k]]:.3g})"
                    if k < flagged.size
                    else ""
                )
            if flagged.size > 3:
                row["more"] = f"{flagged.size - 3} more (cases.csv)"
        rows.append(row)
    df = probs.with_case_columns(pd.DataFrame(rows), res)
    df = df.sort_values("failed", ascending=False, kind="stable")
    k = res.settings.min_case_failures
    if "per_case" in res.levels:
        how = (
            f"Each case with at least {k} failed and {k} successful runs is analysed on its "
            "own; listed are the drivers it flags, family-wise over every case and input "
            f"together (max-T: p < {100 * level:.3g} %, this family's share of the report's "
            "budget). cases.csv lists the same drivers; its 'significant' column is this flag. "
        )
    else:  # no share: say so rather than print a level nobody tested at
        how = (
            f"No case has at least {k} failed and {k} successful runs, so no case is analysed "
            "on its own: the per-case family is not tested and has no share of the report's "
            "budget (its share went to the other families). "
        )
    blocks = [text_block(how + "Cases are sorted by failures.")]
    blocks.append(table_block(df.fillna(""), "Drivers per case (cases.csv)", max_rows=60))
    return Section("Per case", blocks, "cases")


def histograms(res, n_cases: int = 3) -> Section:
    rs = res.runset
    if not all(f"final_rate_err_{a}_deg_s" in rs.runs.columns for a in figures.AXES):
        return Section(
            "Rate errors", [text_block("The runs carry no final rate errors.")], "rate-errors"
        )
    thr = (rs.manifest or {}).get("thresholds", {}).get("rate_error_deg_s")
    blocks = []
    for c in sorted(res.cases, key=lambda c: -c.failed)[:n_cases]:
        if c.failed == 0:
            continue
        rows = np.ones(rs.y.size, bool) if rs.strata is None else rs.strata == c.case
        blocks.append(
            figure_block(
                png_bytes(
                    figures.rate_error_histogram(rs.runs[rows], rs.y[rows], thr, f"case {c.case}")
                ),
                f"Case {c.case}: final rate errors binned, failed runs red, successful blue "
                "(as Gambone Fig. 16).",
            )
        )
    return Section("Rate errors", blocks, "rate-errors")


def second_opinion(res) -> Section:
    d = res.drivers
    if res.forest is None or "forest_rank" not in d:
        return Section(
            "Second opinion", [text_block("Not computed (too few failures).")], "second-opinion"
        )
    top = d.sort_values("forest_rank", kind="stable").head(15)
    blocks = [
        text_block(
            f"A random forest (held-out AUC {res.forest.test_auc_:.3f}) ranks the inputs by how "
            "much its held-out AUC drops when one is shuffled. Its ranking is shown beside the "
            "kernel-density ranking for comparison only: it is not a test and flags nothing. "
            "The two rankings can differ where inputs are correlated (the forest may take an "
            "input's information from another) and where inputs act together."
        ),
        table_block(
            _present(top, ["forest_rank", "factor", "rank", "forest_importance"]).rename(
                columns={"rank": "kernel-density rank", "forest_importance": "AUC drop"}
            ),
            "The forest's 15 highest-ranked inputs, with their kernel-density rank",
            max_rows=15,
        ),
    ]
    return Section("Second opinion", blocks, "second-opinion")


def failed_runs(res, max_rows: int = 100) -> Section:
    rs = res.runset
    runs = rs.runs[rs.y]
    cols = [
        c
        for c in (
            "run_id",
            "case",
            "reason",
            "final_rate_err_roll_deg_s",
            "final_rate_err_pitch_deg_s",
            "final_rate_err_yaw_deg_s",
        )
        if c in runs
    ]
    df = runs[cols].copy()
    if rs.kind == "campaign" and "run_id" in df:
        where = shlex.quote(str(rs.source))
        df["replay"] = [f"rcsim campaign replay {where} {int(r)}" for r in df["run_id"]]
    blocks = [
        text_block(
            f"{len(df)} failed runs"
            + (
                "; the replay command re-flies one alone and writes its history and plots."
                if "replay" in df
                else "."
            )
        )
    ]
    blocks.append(table_block(df, "Failed runs", max_rows=max_rows))
    return Section("Failed runs", blocks, "failed-runs")


def notes(res) -> Section:
    rs = res.runset
    items = list(rs.notes)
    if res.timings_s:
        items.append(
            "analysis time: " + ", ".join(f"{k} {v:.1f} s" for k, v in res.timings_s.items())
        )
    return Section("Notes", [text_block(*items) if items else text_block("None.")], "notes")


def no_failures(res) -> Section:
    rs = res.runset
    what = "failed" if not rs.y.any() else "successful"
    return Section(
        "No failures to analyse",
        [
            text_block(
                f"None of the {rs.y.size} runs is {what} (outcome column '{rs.outcome}'), so "
                f"there is "
                "nothing to compare: no input can be a driver. drivers.csv and pairs.csv hold "
                "no rows."
            )
        ],
        "no-failures",
    )


def driver_sections(res) -> list:
    """Every section of the analysis, in reading order."""
    if not res.has_failures:
        return [summary(res), no_failures(res), notes(res)]
    return [
        summary(res),
        method(res),
        drivers(res),
        mechanism.section(res),
        pairs(res),
        report_boxes.section(res),
        cases(res),
        probs.outcomes(res),
        histograms(res),
        second_opinion(res),
        failed_runs(res),
        notes(res),
    ]
