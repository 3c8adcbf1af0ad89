"""Generated lookup tables on the nominal vehicle: each case's error before and after tuning.

For each vehicle, generates its lookup table twice -- the paper's rule alone
(``tune_rounds=0``, still flown closed loop for the nominal check) and with the closed-loop
tuning of ``rcsim/lookup/row_tuning.py`` (the default) -- and prints, before -> after: the
generation time (wall clock, one process), how many cases meet the target (every axis within
half the 0.04 deg/s failure threshold after the row's firing), how many nominal cases end
failed (at or beyond 0.04 deg/s at the end of the check's flight), the worst end error and
row error (deg/s), the firings the controller started over the 26 cases, how many rows the
tuning changed and the reasons of the cases that still miss.  The numbers of
``docs/lookup.md`` section 6.

``service16-paper-profile`` is ``docs/examples/service16.toml`` without its ``[control]`` table
(the paper's 0.06 deg/s rate dead band instead of its 0.005): a user's Apollo-like vehicle
flown with the paper's flight software.

Usage::

    python benchmarks/table_generation_nominal.py [VEHICLE ...]
"""

from __future__ import annotations

import re
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from rcsim.lookup.generation import generate_table, is_coupled  # noqa: E402
from rcsim.lookup.row_tuning import DEFAULT_ROUNDS  # noqa: E402
from rcsim.spacecraft.vehicle import Vehicle  # noqa: E402

VEHICLES = {
    "paper": "paper",
    "canted16": "canted16",
    "canted12": "canted12",
    "service16": str(ROOT / "docs/examples/service16.toml"),
    "service16-paper-profile": None,  # written below
    "smallsat150": str(ROOT / "tests/lookup/vehicles/smallsat150.toml"),
    "smallsat8": str(ROOT / "docs/examples/smallsat8.toml"),
}


def paper_profile(path: Path, into: Path) -> str:
    """``path`` without its ``[control]`` table, written to ``into``."""
    text = path.read_text(encoding="utf-8")
    into.write_text(re.sub(r"\n\[control\].*?(?=\n\[)", "\n", text, flags=re.S), encoding="utf-8")
    return str(into)


def generate(ref: str, rounds: int):
    from rcsim.lookup.channel_generation import generate_channel_table
    from rcsim.lookup.table_generation import generate_jet_table

    vehicle = Vehicle.load(ref)
    start = time.perf_counter()
    if is_coupled(vehicle):
        gen = generate_channel_table(vehicle, tune_rounds=rounds)
    else:
        gen = generate_jet_table(vehicle, tune_rounds=rounds)
    return gen, time.perf_counter() - start


def main(names: list[str]) -> None:
    tmp = Path(tempfile.mkdtemp())
    VEHICLES["service16-paper-profile"] = paper_profile(
        ROOT / "docs/examples/service16.toml", tmp / "service16_paper_profile.toml"
    )
    generate_table(Vehicle.load("paper"))  # compile and cache before timing
    print(
        "| vehicle | generation [s] | cases within the target | nominal runs ending failed "
        "(>= 0.04 deg/s) | worst end error [deg/s] | worst row error [deg/s] | firings "
        "(26 cases) | rows tuned | cases missed (reason: cases) |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for name in names or list(VEHICLES):
        ref = VEHICLES[name]
        assert ref is not None
        before, t0 = generate(ref, 0)
        after, t1 = generate(ref, DEFAULT_ROUNDS)
        b, a = before.nominal, after.nominal
        missed: dict[str, list[int]] = {}
        for case, reason, met in zip(after.table.case, a.reason, a.met, strict=True):
            if not met:
                missed.setdefault(reason.split(":")[0], []).append(int(case))
        named = "; ".join(f"{r}: {', '.join(map(str, c))}" for r, c in missed.items())

        def end(n):
            return np.degrees(np.abs(n.end_rate_err_rad_s).max(axis=1))

        print(
            f"| {name} | {t0:.1f} -> {t1:.1f} | {int(b.met.sum())} -> {int(a.met.sum())} | "
            f"{int((end(b) >= 0.04).sum())} -> {int((end(a) >= 0.04).sum())} | "
            f"{end(b).max():.4f} -> {end(a).max():.4f} | "
            f"{np.degrees(b.worst_rad_s).max():.4f} -> {np.degrees(a.worst_rad_s).max():.4f} | "
            f"{int(b.firings.sum())} -> {int(a.firings.sum())} | {int(a.tuned.sum())} | "
            f"{named or 'none'} |"
        )


if __name__ == "__main__":
    main(sys.argv[1:])
