"""The per-jet response database (:mod:`rcsim.lookup.response_database`) against rigid-body physics.

Oracle: with no dispersion, a paper-vehicle jet fired alone from rest torques one principal axis
(Table 2 layout, ``rcsim/models/vehicle/README.md``), so Euler's equations have no gyroscopic term
and the rate change is exactly ``tau t / I`` (about that axis; zero about the others), and the CG
velocity change is ``F t / m`` along the jet (Newton).  Tolerance 1e-9 relative: the flight
is an RK4 integration of a constant torque about a principal axis, exact to rounding.

With valve timing (command delay ``d``, the jet's latencies ``o`` and ``c``) the pulse thrusts
``max(0, t + c - o)`` instead of ``t`` (the timing model, ``rcsim/spacecraft/valves.py``): the same
oracles with that time, which the frame's ``thrust_s`` must be (1e-12), and the summary's slope
is per second of thrust.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from rcsim.analysis.engine.response_files import write_response_database
from rcsim.lookup.response_database import RATE_COLUMNS, response_database, response_summary
from rcsim.spacecraft.vehicle import Vehicle
from rcsim.spacecraft.vehicle.mjcf import force_torque


@pytest.mark.parametrize("delays", [False, True])
def test_single_jet_response_is_euler_and_newton(delays):
    flying = Vehicle.load("paper")
    d = replace(flying.definition, three_sigma={})
    lag = np.zeros(d.n_jets)
    if delays:  # per jet: closing latency minus opening latency from -7 to +8 ms
        opens = 0.002 + 0.0005 * np.arange(d.n_jets)
        closes = 0.009 - 0.0005 * np.arange(d.n_jets)
        jets = tuple(
            replace(jet, open_delay_s=o, close_delay_s=c)
            for jet, o, c in zip(d.jets, opens, closes, strict=True)
        )
        d = replace(d, jets=jets, command_delay_s=0.006)
        lag = closes - opens
    flying = flying.edited(d, "no dispersions" + (", valve delays" if delays else ""))
    frame = response_database(flying, n_vehicles=2, on_times_s=(0.01, 0.04, 0.2), nthread=1)
    assert ("thrust_s" in frame) == delays
    ft = force_torque(d)
    inertia = np.diag(d.inertia_kg_m2)
    for _, row in frame.iterrows():
        j = row["jet_number"] - 1
        t = max(0.0, row["on_time_s"] + lag[j])
        if delays:
            assert row["thrust_s"] == pytest.approx(t, rel=1e-12, abs=1e-15)
        expect_w = ft[3:, j] * t / inertia
        got_w = row[list(RATE_COLUMNS)].to_numpy(float)
        np.testing.assert_allclose(got_w, expect_w, rtol=1e-9, atol=1e-15)
        expect_v = ft[:3, j] * t / d.mass_kg
        got_v = row[["dv_x_m_s", "dv_y_m_s", "dv_z_m_s"]].to_numpy(float)
        np.testing.assert_allclose(got_v, expect_v, rtol=1e-9, atol=1e-15)
    summary = response_summary(frame)
    np.testing.assert_allclose(
        summary["dw_roll_rad_s_per_s"].to_numpy(), ft[3] / inertia[0], rtol=1e-9, atol=1e-15
    )
    assert (summary["dw_roll_rad_s_per_s_sd"] < 1e-12).all()  # identical vehicles


def test_files_are_written_and_traceable(tmp_path):
    files = write_response_database("canted16", tmp_path / "db.parquet", n_vehicles=3)
    frame = pd.read_parquet(files.database)
    assert len(frame) == 16 * 6 * 3
    import pyarrow.parquet as pq

    meta = pq.read_schema(files.database).metadata[b"rcsim"].decode()
    assert "canted16.toml" in meta and '"seed": 1' in meta
    assert files.summary.exists() and files.plot.stat().st_size > 10_000
    # the dispersion spread is real: thrust and pointing differ between the vehicles
    assert (pd.read_csv(files.summary)["dw_roll_rad_s_per_s_sd"] > 0).any()


def test_on_times_below_the_minimum_on_time_are_not_flown(tmp_path, capsys):
    """Issue 18 review: a vehicle whose valves make no pulse under 15 ms (canted16 edited:
    ``min_on_s = 0.015``) gets no 10 ms rows, which would all be zero (the valve drops the
    command: rcsim.spacecraft.propulsion.apply_valve_limits) and pull every slope toward zero; the
    CLI says so, and the Parquet metadata records the dropped on-time, the vehicle file's
    SHA-256 (of its bytes) and the code version."""
    import hashlib
    import json

    import pyarrow.parquet as pq

    from rcsim.analysis.apps.cli import main
    from rcsim.spacecraft.vehicle import resolve_vehicle

    text = resolve_vehicle("canted16").read_text()
    assert "min_on_s = 0.010" in text
    vehicle = tmp_path / "v.toml"
    vehicle.write_text(text.replace("min_on_s = 0.010", "min_on_s = 0.015", 1))
    out = tmp_path / "db.parquet"
    assert main(["lookup", "database", "--vehicle", str(vehicle), "--out", str(out),
                 "--vehicles", "2"]) == 0  # fmt: skip
    assert "on-times 10 ms, below the vehicle's minimum on-time 15 ms" in capsys.readouterr().out
    frame = pd.read_parquet(out)
    assert sorted(set(frame["on_time_s"])) == [0.02, 0.04, 0.08, 0.16, 0.32]
    assert len(frame) == 16 * 5 * 2
    # Every flown pulse moved the vehicle (a jet fired alone from rest always torques it).
    assert (np.abs(frame[list(RATE_COLUMNS)].to_numpy()).max(axis=1) > 0).all()
    meta = json.loads(pq.read_schema(out).metadata[b"rcsim"])
    assert meta["vehicle_sha256"] == hashlib.sha256(vehicle.read_bytes()).hexdigest()
    assert meta["dropped_on_times_s"] == [0.01] and meta["min_on_s"] == 0.015
    assert {"rcsim", "git_commit", "mujoco"} <= set(meta["code_version"])
