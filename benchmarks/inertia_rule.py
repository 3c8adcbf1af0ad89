"""How often dispersed inertia tensors are no rigid body (issue 18, docs/campaigns.md,
"Physical inertia tensors").

Draws ``--runs`` vehicles at each of several scales of Table 5 (optionally with products of
inertia) through the simulator's own dispersion code (``rcsim.spacecraft.dispersions.apply_draws``
on standard variates of one generator: the same distribution a campaign draws, run streams
aside), and counts the runs whose principal moments break the triangle inequality, i.e. the
runs ``rcsim.spacecraft.simulation.invalid_runs`` refuses to fly.  Printed per scale: that fraction
with its 95 % Clopper-Pearson interval, and whether the inertia rule accepts the scale.

Usage::

    python benchmarks/inertia_rule.py                        # 2,000,000 runs per scale
    python benchmarks/inertia_rule.py --products 100 --runs 200000
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def main() -> None:
    import numpy as np

    from rcsim.analysis.results.proportions import clopper_pearson
    from rcsim.models.tables import load_dispersions
    from rcsim.spacecraft.dispersions import (
        N_MASS_EXTRAS,
        DispersionSigmas,
        apply_draws,
        inertia_scale_limit,
        n_normals,
        n_uniforms,
    )
    from rcsim.spacecraft.vehicle import Vehicle

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=2_000_000)
    ap.add_argument("--scales", type=float, nargs="+", default=[1.0, 3.0, 4.2, 4.5, 5.0, 11.0])
    ap.add_argument("--products", type=float, default=0.0, help="3-sigma of each product [kg m^2]")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    nominal = Vehicle.load().nominal(1)
    n_jets = nominal.n_jets
    table = load_dispersions()
    three = dict(zip(table["name"], table["three_sigma"]))
    three.update(ixy=args.products, ixz=args.products, iyz=args.products)
    limit = inertia_scale_limit(np.diag(nominal.inertia_B[0]), three)
    print(
        f"Table 5, products 3-sigma {args.products:g} kg m^2: the inertia rule allows scale < "
        f"{limit:.4g}; {args.runs:,} runs per scale"
    )
    rng = np.random.default_rng(args.seed)
    batch = 200_000
    for scale in args.scales:
        sigmas = replace(
            DispersionSigmas.from_table(table, scale),
            products_kg_m2=(args.products * scale / 3,) * 3,
        )
        bad = 0
        for start in range(0, args.runs, batch):
            n = min(batch, args.runs - start)
            params, _, _ = apply_draws(
                nominal,
                sigmas,
                rng.standard_normal((n, n_normals(n_jets))),
                rng.random((n, n_uniforms(n_jets))),
                rng.standard_normal((n, N_MASS_EXTRAS)),
            )
            m = np.sort(params.inertia_B, axis=1)
            bad += int(np.sum((m[:, 0] + m[:, 1] < m[:, 2] * (1 - 1e-12)) | (m[:, 0] <= 0)))
        lo, hi = clopper_pearson(bad, args.runs)
        verdict = "accepted" if scale < limit else "refused"
        print(
            f"scale {scale:5g}: {bad:8d} runs no rigid body, {bad / args.runs:.3g} "
            f"(95 % CI {lo:.2g}-{hi:.2g}); {verdict}"
        )


if __name__ == "__main__":
    main()
