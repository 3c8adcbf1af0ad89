"""A limit cycle removed by retuning a vehicle's flight-software profile (issue 27).

``docs/examples/service16.toml`` (15 t, four quads of 440 N jets 2 m from the CG) flies a 5 deg
yaw maneuver and then holds, with the lookup controller and its own channel table
(``rcsim lookup generate --vehicle``), twice: with the paper's profile (every ``[control]``
key the paper's) and with the file's own ``[control]`` (the paper's but
``rate_deadband_deg_s``).  The paper's vehicle with Table 6 flies the same maneuver for
reference.  Per flight: the attitude error after the maneuver, the firing bursts after it (a
burst: firings with less than 2 s between them), their period and the propellant.

Usage::

    python benchmarks/profile_limit_cycle.py [--duration-s 1200]
        [--plot docs/figures/service16_limit_cycle.png]

Writes the figure (attitude error against time, the three flights) and prints a Markdown
table.  Deterministic: one nominal run per flight, no dispersion.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from rcsim.analysis.engine.flight import Scenario, fly  # noqa: E402
from rcsim.lookup.generation import generate_table  # noqa: E402
from rcsim.spacecraft.vehicle import Vehicle  # noqa: E402

SERVICE16 = ROOT / "docs" / "examples" / "service16.toml"
#: The maneuver ends by this time on every flight here (settled within the hold region).
MANEUVER_END_S = 60.0
#: Firings closer than this belong to one burst [s] (a null takes a few cycles).
BURST_GAP_S = 2.0


def bursts(history) -> np.ndarray:
    """Start times of the firing bursts after :data:`MANEUVER_END_S` [s]."""
    fired = history.on_time_s[0].sum(axis=1) > 0  # (n_cycles,): a jet on in the cycle
    t = history.t_s[: fired.size][fired]
    t = t[t > MANEUVER_END_S]
    if t.size == 0:
        return t
    return np.concatenate([t[:1], t[1:][np.diff(t) > BURST_GAP_S]])


def error_deg(history) -> np.ndarray:
    return np.degrees(np.linalg.norm(history.att_err_B[0], axis=1))


def measure(duration_s: float) -> list[dict]:
    scenario = Scenario(
        name="yaw5-hold", duration_s=duration_s, att_cmd_rad=np.radians([0.0, 0.0, 5.0])
    )
    paper = Vehicle.load("paper")
    own = Vehicle.load(SERVICE16)
    before = own.with_control(paper.control.values(), "the paper's profile")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        table = Path(tmp) / "service16.csv"
        generate_table(own).table.to_csv(table)  # the recipe beside it (a channel table)
        flights = [
            ("paper vehicle, Table 6, paper's profile", paper, "table6"),
            ("service16, paper's profile", before, str(table)),
            ("service16, its own [control]", own, str(table)),
        ]
        for label, vehicle, tab in flights:
            history = fly(scenario, "lookup", vehicle=vehicle, table=tab)
            err = error_deg(history)
            late = history.t_s[: err.size] > MANEUVER_END_S
            starts = bursts(history)
            rows.append(
                {
                    "flight": label,
                    "rate_deadband_deg_s": np.degrees(vehicle.control.rate_deadband_rad_s),
                    "err_min_deg": float(err[late].min()),
                    "err_max_deg": float(err[late].max()),
                    "bursts": int(starts.size),
                    "period_s": float(np.diff(starts).mean()) if starts.size > 2 else np.nan,
                    "propellant_kg": float(history.propellant_kg[0]),
                    "t_s": history.t_s[: err.size],
                    "err_deg": err,
                }
            )
    return rows


def plot(rows: list[dict], path: Path, duration_s: float) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(10, 4.2), constrained_layout=True)
    for row, colour in zip(rows, ("0.55", "tab:red", "tab:blue")):
        ax.plot(
            row["t_s"],
            row["err_deg"],
            color=colour,
            lw=1.2,
            label=f"{row['flight']}: {row['bursts']} firing burst"
            + ("" if row["bursts"] == 1 else "s")
            + ", "
            + f"{row['propellant_kg']:.2f} kg",
        )
    ax.axhline(0.7, color="k", ls=":", lw=0.8)
    ax.text(duration_s, 0.71, "maneuver limit + no-firing band (0.7 deg)", ha="right", va="bottom")
    ax.set_ylim(0, 1.2)
    ax.set_xlim(0, duration_s)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("total attitude error [deg]")
    ax.set_title(
        f"5 deg yaw maneuver, then {duration_s - MANEUVER_END_S:.0f} s of hold: "
        "service16's limit cycle, and its retuned profile"
    )
    ax.legend(loc="upper right", fontsize=9)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--duration-s", type=float, default=1200.0)
    p.add_argument("--plot", type=Path, default=ROOT / "docs/figures/service16_limit_cycle.png")
    args = p.parse_args(argv)
    rows = measure(args.duration_s)
    print(
        "| flight | rate deadband [deg/s] | error after the maneuver [deg] | firing bursts "
        "| mean period [s] | propellant [kg] |\n|---|---|---|---|---|---|"
    )
    for r in rows:
        print(
            f"| {r['flight']} | {r['rate_deadband_deg_s']:g} | {r['err_min_deg']:.2f}-"
            f"{r['err_max_deg']:.2f} | {r['bursts']} | {r['period_s']:.0f} | "
            f"{r['propellant_kg']:.3f} |"
        )
    plot(rows, args.plot, args.duration_s)
    print(f"figure: {args.plot}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
