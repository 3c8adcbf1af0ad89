"""The evidence of a refinement search, per searched case: what was proposed, the paired tests
on the search and confirmation seeds, what became of each row and of its mirror, and which
cells changed (:func:`changed_cells`, the loop report's comparison with the paper's Table 7).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from rcsim.analysis.apps.refinement.gate import PairedTest, mirror_rows
from rcsim.lookup.table_edits import axis_cycles, jet_axes
from rcsim.models.tables import AXES, LookupTable


def refused_candidates(iterations: list, case_numbers) -> list[str]:
    """Per searched case, the strictly better candidates the search gate refused, e.g.
    ``round 2: roll +1 cycle (failed 1:0, p=0.5)``; "" when none."""
    out: dict[int, list[str]] = {int(c): [] for c in case_numbers}
    for it in iterations:
        for d in it.get("decisions", []):
            if d["accepted"] or d.get("deferred"):
                continue  # a deferred candidate was judged again (its own decision)
            case = int(d["candidate"].split(":")[0].split()[1])
            move = d["candidate"].split(": ", 1)[1]
            why = f"{d['outcome']} {d['b']}:{d['c']}, p={d['p']:.2g}"
            if d.get("propellant_refused"):
                why += f"; {d['propellant_refused']}"
            if d.get("worse_refused"):
                why += f"; {d['worse_refused']}"
            if d.get("judged_again"):
                why += f"; judged again ({d['judged_again']}) after an interacting change"
            out[case].append(f"round {it['round']}: {move} ({why})")
    return ["; ".join(out[int(c)]) for c in case_numbers]


def test_dict(test: PairedTest) -> dict:
    return {
        "outcome": test.outcome,
        "b": test.b,
        "c": test.c,
        "p": test.p,
        "failed_before": test.failed_before,
        "failed_after": test.failed_after,
        "repeated_before": test.repeated_before,
        "repeated_after": test.repeated_after,
        "accepted": test.passed,
    }


def _moves(delta: np.ndarray, table: LookupTable | None = None, row: int = 0) -> str:
    """A row's change in cycles per axis, e.g. ``yaw -1`` (a channel table's row:
    ``+yaw channel -1``); ``none``."""

    def name(a: int) -> str:
        if table is None or table.recipe is None:
            return AXES[a]
        return f"{'+' if table.rate_cmd[row, a] > 0 else '-'}{AXES[a]} channel"

    parts = [f"{name(a)} {int(d):+d}" for a, d in enumerate(delta) if d]
    return ", ".join(parts) or "none"


def evidence_frame(
    table: LookupTable,
    cases: np.ndarray,
    final: np.ndarray,
    jet_axis: np.ndarray,
    search_tests: dict,
    confirm_tests: dict,
    kept: dict,
    source: dict,
    notes: dict,
    confirmed_on_seed: bool,
    cycle_s: float,
) -> pd.DataFrame:
    """Per searched case: the row's change (in whole ``cycle_s`` cycles), the evidence for it
    and what became of it.

    Columns: ``case_index``, ``decided_on`` (``failed`` or ``failed or repeated``), the search
    seed's counts and paired test of the original row against the proposed one (``search_b``
    better / ``search_c`` worse discordant runs, ``search_p``), the confirmation seed's
    (``confirm_failed_before`` ... ``confirm_p``, empty where nothing was confirmed),
    ``decision`` and, for the mirror case (every rate command negated), ``mirror_case`` and
    ``mirror_decision``.  :func:`refine` adds ``refused`` (:func:`refused_candidates`).
    """
    orig = np.asarray(table.firing_time_s, float)
    c_orig = axis_cycles(orig, jet_axis, cycle_s)
    c_final = axis_cycles(final, jet_axis, cycle_s)
    mirror = mirror_rows(table.rate_cmd)
    pos = {int(c): t for t, c in enumerate(cases)}
    rows = []
    for t, c in enumerate(cases):
        c = int(c)
        st = search_tests[t]
        ct = confirm_tests.get(t)
        involved = t in kept
        row = {
            "case_index": c,
            "decided_on": search_tests[source.get(t, t)].outcome if involved else "",
            "search_failed_before": st.failed_before,
            "search_failed_after": st.failed_after,
            "search_repeated_before": st.repeated_before,
            "search_repeated_after": st.repeated_after,
            "search_runs": st.runs,
            "search_b": st.b if involved else 0,
            "search_c": st.c if involved else 0,
            "search_p": st.p if involved else 1.0,
        }
        for name in ("failed_before", "failed_after", "repeated_before", "repeated_after"):
            row[f"confirm_{name}"] = getattr(ct, name) if ct else pd.NA
        row["confirm_runs"] = ct.runs if ct else pd.NA
        row["confirm_b"] = ct.b if ct else pd.NA
        row["confirm_c"] = ct.c if ct else pd.NA
        row["confirm_p"] = ct.p if ct else np.nan
        if not involved:
            row["decision"] = "unchanged"
        else:
            what = f"mirror of case {int(cases[source[t]]) + 1}" if t in source else "search"
            if not confirmed_on_seed:
                row["decision"] = f"changed ({what}; search gate only)"
            elif kept[t]:
                row["decision"] = f"changed ({what}; confirmed)"
            else:
                row["decision"] = f"reverted ({what}; not confirmed on the confirmation seed)"
        rows.append(row)
    frame = pd.DataFrame(rows)
    mirror_case, mirror_decision = [], []
    for t, c in enumerate(cases):
        c = int(c)
        m = int(mirror[c])
        mirror_case.append(m + 1 if m >= 0 else 0)
        if m < 0:
            mirror_decision.append("no mirror case")
            continue
        if m not in pos:
            mirror_decision.append(f"case {m + 1} not searched")
            continue
        mine, theirs = c_final[c] - c_orig[c], c_final[m] - c_orig[m]
        if (mine == theirs).all():
            mirror_decision.append(
                "consistent: neither changed"
                if not mine.any()
                else f"consistent: both {_moves(mine, table, c)}"
            )
            continue
        tm = pos[m]
        why = notes.get(tm) or notes.get(t)
        if why is None:
            reverted = [x for x in (t, tm) if x in kept and not kept[x]]
            if reverted:
                why = "the change was not confirmed for case " + " and ".join(
                    str(int(cases[x]) + 1) for x in reverted
                )
            else:
                why = "each row changed on its own evidence"
        mirror_decision.append(
            f"differs: case {c + 1} {_moves(mine, table, c)}, case {m + 1} "
            f"{_moves(theirs, table, m)} ({why})"
        )
    frame.insert(1, "mirror_case", mirror_case)
    frame["mirror_decision"] = mirror_decision
    return frame


def add_propellant(evidence: pd.DataFrame, search_fuel: dict, confirm_fuel: dict, kept: dict):
    """Add each searched case's propellant evidence to :func:`evidence_frame`'s rows (in
    place): the mean propellant per run [kg] of the original and the proposed row, and its
    change [%], on the search seed and (where flown) the confirmation seed, and
    ``propellant_note``, why the rule refused a row (:mod:`~rcsim.analysis.apps.refinement.
    propellant`).  A row reverted for propellant says so in its ``decision``."""
    for where, fuel in (("search", search_fuel), ("confirm", confirm_fuel)):
        got = [fuel.get(t) for t in range(len(evidence))]
        evidence[f"{where}_propellant_before_kg"] = [v.before_kg if v else np.nan for v in got]
        evidence[f"{where}_propellant_after_kg"] = [v.after_kg if v else np.nan for v in got]
        evidence[f"{where}_propellant_change_pct"] = [v.rise_pct if v else np.nan for v in got]
    notes = []
    for t in range(len(evidence)):
        v = confirm_fuel.get(t)
        if v is None or v.passes:
            notes.append("")
            continue
        notes.append(f"confirmation seed: {v.reason}")
        if t in kept and not kept[t]:
            evidence.loc[t, "decision"] = str(evidence.loc[t, "decision"]).replace(
                "not confirmed on the confirmation seed",
                "propellant not paid for on the confirmation seed",
            )
    evidence["propellant_note"] = notes


def changed_cells(old: LookupTable, new: LookupTable, cycle_s: float) -> pd.DataFrame:
    """Per case and axis whose firing time changed: ``case, axis, old_cycles, new_cycles``
    (whole control cycles of ``cycle_s`` [s])."""
    jet_axis = jet_axes(old)
    a_old = axis_cycles(old.firing_time_s, jet_axis, cycle_s)
    a_new = axis_cycles(new.firing_time_s, jet_axis, cycle_s)
    rows = [
        {
            "case": int(old.case[c]),
            "axis": AXES[a],
            "old_cycles": int(a_old[c, a]),
            "new_cycles": int(a_new[c, a]),
        }
        for c, a in np.argwhere(a_old != a_new)
    ]
    return pd.DataFrame(rows, columns=["case", "axis", "old_cycles", "new_cycles"])
