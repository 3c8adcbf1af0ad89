"""Plot one rate case of three nominal campaigns: the service module, its rigid twin, and the
service module with the fixed profile (docs/flexible_showcase.md).

    python examples/service_module/plot_excitation.py SM_DIR RIGID_DIR FIX_DIR CASE OUT.png

The DIRs are ``rcsim campaign run``s of ``nominal.toml``, ``nominal_rigid.toml`` and
``nominal_fixed.toml`` (histories kept); CASE a case name
(``rate-04``).  Top: the hub's roll rate error; middle: the +y wing's hinge angle; bottom: the
roll jets' signed on-time per cycle.
"""

from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402

ROLL_PLUS = ("jet_02_on_s", "jet_04_on_s")  # Table 2: +roll
ROLL_MINUS = ("jet_01_on_s", "jet_03_on_s")


def history(where: Path, case: str) -> pd.DataFrame:
    runs = pd.read_parquet(where / "runs.parquet")
    run_id = int(runs.loc[runs["case"] == case, "run_id"].iloc[0])
    return pd.read_parquet(where / "histories" / f"run-{run_id:07d}.parquet")


def main(sm: str, rigid: str, fix: str, case: str, out: str) -> None:
    flights = [
        ("service module, paper's profile", history(Path(sm), case), "C3"),
        ("rigid twin, paper's profile", history(Path(rigid), case), "0.5"),
        ("service module, rate dead band 0.04 deg/s", history(Path(fix), case), "C0"),
    ]
    fig, ax = plt.subplots(3, 1, sharex=True, figsize=(8.0, 6.4))
    for label, h, colour in flights:
        ax[0].plot(h["t_s"], h["rate_err_roll_deg_s"], color=colour, lw=1.1, label=label)
        if "wing_plus_y_hinge_deg" in h:
            ax[1].plot(h["t_s"], h["wing_plus_y_hinge_deg"], color=colour, lw=1.1)
        roll = sum(h[c] for c in ROLL_PLUS) - sum(h[c] for c in ROLL_MINUS)
        ax[2].step(h["t_s"], roll, where="post", color=colour, lw=1.0)
    for y, style, text, va in (
        (0.06, "--", "paper's dead band", "bottom"),
        (0.04, ":", "failure", "top"),
    ):
        for sign in (1, -1):
            ax[0].axhline(sign * y, ls=style, color="k", lw=0.7)
        ax[0].text(8.3, y, text, fontsize=7, va=va)
    ax[0].set_ylabel("hub roll rate error\n[deg/s]")
    ax[0].legend(fontsize=7, loc="upper right")
    ax[1].set_ylabel("+y wing hinge\n[deg]")
    ax[2].set_ylabel("roll jets on-time\nper cycle [s]")
    ax[2].set_xlabel("time [s]")
    ax[0].set_title(f"service module, {case} (Gambone Table 3), nominal: the wing rings the hub")
    fig.tight_layout()
    fig.savefig(out, dpi=80)


if __name__ == "__main__":
    main(*sys.argv[1:6])
