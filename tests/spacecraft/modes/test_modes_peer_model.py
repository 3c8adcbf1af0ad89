"""The vehicle-file path builds the mechanism the slosh / hinged-panel peer builds by hand
(``benchmarks/peer_modes.py``'s ``build_scenario``, written independently from Basilisk's
definitions, docs/basilisk_peer.md): each peer scenario written as a vehicle file (its hub
and mode composed into the file's whole-vehicle ``[mass]`` by the parallel-axis theorem, here)
and both models released from the same state, 60 s of RK4 at 10 ms without jets.

* panel: the same bodies, so the same trajectory to rounding (measured 2e-15 of each
  channel's peak; tolerance 1e-12);
* slosh: the peer gives its particle 1e-12 kg m^2, rcsim's point mass m (1 mm)^2 = 3.5e-4
  kg m^2 (POINT_GYRATION_M) taken out of the hub, which moves the hub's inertia by 1.4e-7 of
  its 2457 kg m^2 about z (measured 3e-7 of the peaks; tolerance 1e-6)."""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import mujoco
import numpy as np
import pytest

from rcsim.spacecraft.vehicle import Vehicle

ROOT = Path(__file__).resolve().parents[3]


@pytest.fixture(scope="module")
def peer():
    spec = importlib.util.spec_from_file_location("peer_modes", ROOT / "benchmarks/peer_modes.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _response(model: mujoco.MjModel) -> np.ndarray:
    """Hub rates and the mode's coordinate and rate, (6000, 5), released from a yaw rate of
    0.2 deg/s and the mode displaced by 0.01 (m or rad)."""
    data = mujoco.MjData(model)
    data.qvel[5] = math.radians(0.2)
    data.qpos[7] = 0.01
    out = np.empty((6000, 5))
    for k in range(6000):
        mujoco.mj_step(model, data)
        out[k] = [*data.qvel[3:6], data.qpos[7], data.qvel[6]]
    return out


@pytest.mark.parametrize(("scenario", "tolerance"), [("panel", 1e-12), ("slosh", 1e-6)])
def test_a_vehicle_file_builds_the_peers_mechanism(tmp_path, peer, scenario, tolerance):
    path = tmp_path / "v.toml"
    path.write_text(peer.vehicle_file_text(scenario, peer.PARAMS), encoding="utf-8")
    model = Vehicle.load(path).flight_model
    model.opt.timestep = 0.01  # the peer's step (the file leaves rcsim's default)
    mine = _response(model)
    theirs = _response(peer.build_scenario(scenario, peer.PARAMS, 0.01))
    moving = np.abs(theirs).max(axis=0) > 0  # the planar scenarios leave roll and pitch at 0
    error = np.abs(mine - theirs).max(axis=0)[moving] / np.abs(theirs).max(axis=0)[moving]
    assert moving.sum() >= 3 and error.max() < tolerance
    # and what stays still in the peer's stays still in rcsim's (to the same relative bound)
    assert np.abs(mine[:, ~moving]).max(initial=0.0) <= tolerance * np.abs(theirs).max()
