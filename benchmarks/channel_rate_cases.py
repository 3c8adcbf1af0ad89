"""The 26 rate cases on a coupled vehicle: its channel lookup table against the allocator.

Generates the vehicle's channel table (``rcsim/lookup/channel_generation.py``), then flies the 26
rate cases of Table 3 from rest on the nominal vehicle for 20 s (a campaign's duration) with the
lookup controller on that table and with the allocator controller, and prints per case the
final rate error on the commanded axes and on the others (and the largest off-axis rate at any
cycle), then the totals: firings, propellant, pulses dropped by the valves.  The numbers of
``docs/lookup.md`` section 4.

Usage::

    python benchmarks/channel_rate_cases.py [--vehicle canted16]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from rcsim.lookup.channel_generation import generate_channel_table  # noqa: E402
from rcsim.lookup.registry import make_controller  # noqa: E402
from rcsim.spacecraft.navigation import Guidance  # noqa: E402
from rcsim.spacecraft.simulation import simulate_batch  # noqa: E402
from rcsim.spacecraft.vehicle import Vehicle  # noqa: E402


def fly(vehicle: Vehicle, controller, rate: np.ndarray) -> dict:
    n = rate.shape[0]
    h = simulate_batch(
        vehicle.nominal(n), controller, Guidance.rate(rate), 20.0, vehicle=vehicle, nthread=1
    )
    cmd = rate != 0
    final = np.degrees(np.abs(h.final.rate_err_B))
    flown = np.degrees(np.abs(h.omega_B))
    return {
        "on": np.where(cmd, final, 0).max(axis=1),
        "off": np.where(~cmd, final, 0).max(axis=1),
        "off_any": np.where(~cmd[:, None, :], flown, 0).max(axis=(1, 2)),
        "firings": h.propulsion.firings.sum(axis=1),
        "propellant_g": h.propulsion.propellant_kg(vehicle.isp_s) * 1e3,
        "dropped": int(h.propulsion.dropped.sum()),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--vehicle", default="canted16")
    args = parser.parse_args()
    vehicle = Vehicle.load(args.vehicle)
    generated = generate_channel_table(Vehicle.load(args.vehicle))
    rate = np.asarray(generated.table.rate_cmd, float)
    with tempfile.TemporaryDirectory() as tmp:
        table = Path(tmp) / f"{args.vehicle}.csv"
        generated.table.to_csv(table)  # as `rcsim lookup generate --vehicle` writes it
        lookup = make_controller("lookup", vehicle, table=table)
    res = {
        "channel table": fly(vehicle, lookup, rate),
        "allocator": fly(vehicle, make_controller("allocator", vehicle), rate),
    }
    sym = {-1: "-", 0: "0", 1: "+"}
    print("| case | signs | " + " | ".join(f"{k}: on-axis / off-axis / off any cycle" for k in res))
    for c in range(rate.shape[0]):
        signs = "(" + ",".join(sym[int(x)] for x in np.sign(rate[c])) + ")"
        cells = [
            f"{r['on'][c]:.4f} / {r['off'][c]:.4f} / {r['off_any'][c]:.4f}" for r in res.values()
        ]
        print(f"| {c + 1} | {signs} | " + " | ".join(cells) + " |")
    axes = (rate != 0).sum(axis=1)
    for name, r in res.items():
        print(
            f"{name}: max on-axis {r['on'].max():.4f} deg/s, off-axis final {r['off'].max():.4f}, "
            f"off-axis any cycle {r['off_any'].max():.4f}; firings {int(r['firings'].sum())}, "
            f"propellant {r['propellant_g'].sum():.1f} g (one axis "
            f"{r['propellant_g'][axes == 1].sum():.1f}, two or three "
            f"{r['propellant_g'][axes > 1].sum():.1f}); dropped pulses {r['dropped']}"
        )


if __name__ == "__main__":
    main()
