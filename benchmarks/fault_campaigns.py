"""Campaign-like evidence for issue 11: failures and repeated firings with sensors, delays and
jet faults, for the static table, the adaptive controller and (jet faults) the regenerated table.

Until the campaign spec carries ``[dispersions.sensor|timing|fault]`` (``docs/faults.md``), this
flies the default campaign's work directly: the 26 rate cases of Table 3 commanded from rest,
``--runs-per-case`` runs each with Table 5 dispersions (seed 1), 20 s, and scores every run with
the campaign's own outcome rules (:func:`rcsim.analysis.campaign.outcomes.outcomes`, failure
threshold 0.04 deg/s as in ``rcsim campaign example``).  Per configuration and controller it
prints the failed percentage, the mean firing events to reach the rate (summed over the axes)
and the percentage of runs with a repeated firing (more than one event on some axis).

Usage: ``python benchmarks/fault_campaigns.py [--runs-per-case 20] [--markdown]``.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from rcsim.analysis.campaign.outcomes import outcomes  # noqa: E402
from rcsim.lookup.adaptive import AdaptiveLookupController, AdaptParams  # noqa: E402
from rcsim.lookup.pattern_recognition import LookupController, load_default_table  # noqa: E402
from rcsim.lookup.table_generation import generate_table  # noqa: E402
from rcsim.models.tables import load_dispersions, load_rate_cases  # noqa: E402
from rcsim.spacecraft.dispersions import DispersionSigmas, draw_runs  # noqa: E402
from rcsim.spacecraft.effect_draws import (  # noqa: E402
    FaultSpec, SensorSpec, TimingSpec, draw_faults, draw_sensors, draw_timing,
)
from rcsim.spacecraft.navigation import Guidance  # noqa: E402
from rcsim.spacecraft.simulation import simulate_batch  # noqa: E402
from rcsim.spacecraft.vehicle import VehicleParams, load_model  # noqa: E402

SEED, DURATION_S, THRESHOLD_DEG_S = 1, 20.0, 0.04
ROTATION_JETS = [1, 2, 3, 4, 9, 10, 11, 12, 13, 14, 15, 16]
SENSOR = {"att_noise_deg": 0.003, "rate_noise_deg_s": 0.001, "att_bias_sigma_deg": 0.003,
          "rate_bias_sigma_deg_s": 0.003, "rate_walk_deg_s_per_sqrt_s": 0.0005}
TIMING = {"command_delay_s": 0.005, "open_delay_s": 0.008, "open_delay_sigma_s": 0.001,
          "close_delay_s": 0.005, "close_delay_sigma_s": 0.001}


def configurations():
    return {
        "Table 5 only": {},
        "+ sensor noise and biases": {"sensor": SENSOR},
        "+ command and valve delays": {"timing": TIMING},
        "+ noise and delays": {"sensor": SENSOR, "timing": TIMING},
        "+ one jet at 80 % thrust": {"fault": {"mode": "degraded", "jets": ROTATION_JETS,
                                               "thrust_factor": 0.8}},
        "+ one jet failed off": {"fault": {"mode": "off", "jets": ROTATION_JETS,
                                           "time_s": 0.0}},
    }


def fly(config: dict, controller: str, n_per_case: int, model, tables: dict) -> dict:
    cases = load_rate_cases()
    rate = np.repeat(np.asarray(cases.rate_cmd, float), n_per_case, axis=0)
    n = rate.shape[0]
    ids = np.arange(n)
    params = draw_runs(VehicleParams.nominal(1, model), DispersionSigmas.from_table(
        load_dispersions()), SEED, ids).params
    kw = {}
    noise = 0.0
    if "sensor" in config:
        spec = SensorSpec.from_mapping(config["sensor"])
        kw["sensors"], kw["sensor_streams"] = draw_sensors(spec, SEED, ids)
        noise = float(spec.rate_noise_rad_s.max())
    if "timing" in config:
        kw["timing"] = draw_timing(TimingSpec.from_mapping(config["timing"]), SEED, ids)
    groups = {(): ids}
    if "fault" in config:
        kw["faults"], drawn = draw_faults(FaultSpec.from_mapping(config["fault"]), SEED, ids)
        if controller == "regenerated" and config["fault"]["mode"] == "off":
            jet = drawn.fault_jet.to_numpy()
            groups = {(int(j),): ids[jet == j] for j in np.unique(jet)}
    failed = np.zeros(n, bool)
    firings = np.zeros(n)
    repeated = np.zeros(n, bool)
    for jets_off, runs in groups.items():
        if controller == "adaptive":
            ctl = AdaptiveLookupController(load_default_table(),
                                           adapt=AdaptParams(rate_noise_rad_s=noise))
        elif controller == "regenerated" and jets_off:
            if jets_off not in tables:
                tables[jets_off] = generate_table(jets_off=jets_off, model=model).table
            ctl = LookupController(tables[jets_off], jets_off=jets_off)
        else:
            ctl = LookupController(load_default_table())
        sub = {k: (v.take(runs) if hasattr(v, "take") and k != "sensor_streams" else v)
               for k, v in kw.items()}
        for k in ("sensors", "timing", "faults"):
            if k in sub:
                sub[k] = type(kw[k])(**{f: getattr(kw[k], f)[runs] for f in vars(kw[k])})
        if "sensor_streams" in sub:
            sub["sensor_streams"] = [kw["sensor_streams"][i] for i in runs]
        hist = simulate_batch(params.take(runs), ctl, Guidance.rate(rate[runs]), DURATION_S,
                              model=model, **sub)
        out = outcomes(hist, SimpleNamespace(rate_threshold_rad_s=np.radians(THRESHOLD_DEG_S),
                                             attitude_threshold_rad=None), 0.04, params.isp_s)
        ev = out[[c for c in out.columns if c.startswith("firings_to_rate_")]].to_numpy()
        failed[runs] = out["failed"].to_numpy(bool)
        firings[runs] = np.nansum(ev, axis=1)
        repeated[runs] = (ev > 1).any(axis=1)
    return {"failed_pct": 100 * failed.mean(), "firings": firings.mean(),
            "repeated_pct": 100 * repeated.mean(), "runs": n}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs-per-case", type=int, default=20)
    args = ap.parse_args(argv)
    model = load_model()
    tables: dict = {}
    print("| configuration | controller | runs | failed % | firing events to rate | "
          "runs with a repeated firing % |")
    print("|---|---|---|---|---|---|")
    for name, config in configurations().items():
        ctls = ["static", "adaptive"] + (["regenerated"] if config.get("fault", {}).get(
            "mode") == "off" else [])
        for ctl in ctls:
            r = fly(config, ctl, args.runs_per_case, model, tables)
            print(f"| {name} | {ctl} | {r['runs']} | {r['failed_pct']:.1f} | "
                  f"{r['firings']:.2f} | {r['repeated_pct']:.1f} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
