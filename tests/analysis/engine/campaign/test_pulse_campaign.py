"""A campaign of a vehicle file with real pulses and a blowdown tank, their dispersions drawn
per run and recorded in runs.parquet (rcsim.spacecraft.pulse_draws).

Oracles
-------
* The values each run flew are the draws of its own stream (``nominal + sigma z`` per jet,
  ``z`` the run's child ``PULSE`` of its noise stream, :func:`pulse_normals`), recomputed here
  from the stream and compared exactly; their spread is the file's 3-sigma / 3 (loosely: 8
  runs).
* The recorded propellant is the flight's own, kept per jet (pulse-mode Isp): the per-jet
  columns sum to the run's (1e-12, the sum's rounding); that it is ``I / (Isp(u) g0)`` is
  tests/spacecraft/test_pulse_shape.py's oracle.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from rcsim.analysis.engine.campaign.runner import run_campaign
from rcsim.analysis.engine.campaign.spec import load_spec
from rcsim.spacecraft.pulse_draws import pulse_normals
from rcsim.spacecraft.vehicle.definition import packaged_vehicle

SEED = 7
EXTRA = """
[pulse]
model = "exponential"
rise_s = 0.006
tail_s = 0.004
isp_on_time_s = [0.005, 0.03]
isp_s = [180.0, 260.0]

[propellant.blowdown]
gas_volume_m3 = 0.02
pressure_pa = 2.2e6
density_kg_m3 = 1004.0
"""


def test_dispersed_pulses_and_pressure_are_recorded_as_flown(tmp_path):
    text = packaged_vehicle("paper").read_text(encoding="utf-8")
    text = text.replace("[propellant]\n", "[propellant]\nmass_kg = 40.0\n", 1)
    head, sep, rest = text.partition("[dispersions]")
    assert sep  # paper.toml has a [dispersions] table (Table 5) to add to
    text = (
        head + sep + "\npulse_rise_s = 0.003\npulse_tail_s = 0.0015\ntank_pressure_pa = 3e5" + rest
    )
    (tmp_path / "v.toml").write_text(text + EXTRA, encoding="utf-8")
    spec = tmp_path / "spec.toml"
    spec.write_text(
        f'seed = {SEED}\nruns_per_case = 4\nvehicle = "v.toml"\n[scenario]\n'
        'kind = "rate-cases"\ncases = [1, 13]\nduration_s = 2.0\n[controller]\n'
        'name = "phase-plane"\n',
        encoding="utf-8",
    )
    out = tmp_path / "out"
    run_campaign(load_spec(spec), out, progress=False)
    runs = pd.read_parquet(out / "runs.parquet").sort_values("run_id")
    assert not runs["sim_failed"].any()
    z = pulse_normals(SEED, runs["run_id"].to_numpy(), 16)
    rise = np.maximum(0.006 + 0.001 * z[:, :16], 0.0).mean(axis=1)
    tail = np.maximum(0.004 + 0.0005 * z[:, 16:32], 0.0).mean(axis=1)
    np.testing.assert_array_equal(runs["pulse_rise_mean_s"], rise)
    np.testing.assert_array_equal(runs["pulse_tail_mean_s"], tail)
    np.testing.assert_array_equal(runs["impulse_bit_scale_mean"], 1.0)
    np.testing.assert_array_equal(runs["tank_pressure_pa"], 2.2e6 + 1e5 * z[:, -1])
    assert runs["tank_pressure_pa"].std() > 0.3e5
    # The per-jet propellant is the flight's own (pulse-mode Isp), summing to the run's.
    per_jet = runs[[f"jet_{j:02d}_propellant_kg" for j in range(1, 17)]].sum(axis=1)
    np.testing.assert_allclose(runs["propellant_kg"], per_jet, rtol=1e-12)
    assert (runs["propellant_kg"] > 0).all()
