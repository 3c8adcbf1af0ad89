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

from rcsim.spacecraft.modes.definition import POINT_GYRATION_M
from rcsim.spacecraft.vehicle import Vehicle

ROOT = Path(__file__).resolve().parents[3]


@pytest.fixture(scope="module")
def peer():
    spec = importlib.util.spec_from_file_location("peer_modes", ROOT / "benchmarks/peer_modes.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _point(m, r):
    r = np.asarray(r, float)
    return m * (r @ r * np.eye(3) - np.outer(r, r))


def _file(pm, mode_mass, mode_cg, mode_inertia, block: str) -> str:
    hub_m, hub_c = pm.HUB_MASS_KG, np.asarray(pm.CG_B, float)
    mass = hub_m + mode_mass
    cg = (hub_m * hub_c + mode_mass * np.asarray(mode_cg, float)) / mass
    inertia = np.diag(pm.INERTIA_B) + _point(hub_m, hub_c - cg)
    inertia = (inertia + mode_inertia + _point(mode_mass, np.asarray(mode_cg) - cg)).tolist()
    jets = "".join(
        f"[[jet]]\nposition_m = {pos}\ndirection = {d}\nthrust_n = {pm.THRUST_N}\n"
        for _, pos, d in pm.JETS
    )
    return (
        f"[mass]\nmass_kg = {mass!r}\ncg_m = [{', '.join(repr(float(x)) for x in cg)}]\n"
        f"inertia_kg_m2 = [{inertia[0][0]!r}, {inertia[1][1]!r}, {inertia[2][2]!r}]\n"
        f"products_kg_m2 = [{inertia[0][1]!r}, {inertia[0][2]!r}, {inertia[1][2]!r}]\n"
        "[physics]\ntimestep_s = 0.01\n" + jets + block
    )


def _slosh(pm) -> str:
    s = pm.SLOSH
    own = s["mass_kg"] * POINT_GYRATION_M**2 * np.eye(3)
    block = (
        f'[[slosh]]\nname = "mode"\nmodel = "spring"\nmass_kg = {s["mass_kg"]!r}\n'
        f"position_m = {s['r_PB_B']}\ndirection = {s['pHat_B']}\n"
        f"frequency_hz = {pm.SLOSH_HZ}\ndamping_ratio = {pm.SLOSH_ZETA}\n"
    )
    return _file(pm, s["mass_kg"], s["r_PB_B"], own, block)


def _panel(pm) -> str:
    p = pm.PANEL
    h = np.asarray(p["dcm_HB"], float)
    own = h.T @ np.diag(p["IPntS_S"]) @ h  # about the panel's CG, B axes
    offset = (-p["d_m"] * h[0]).tolist()  # the CG at -d h1 from the hinge
    i = own.tolist()
    block = (
        f'[[appendage]]\nname = "mode"\nmass_kg = {p["mass_kg"]!r}\n'
        f"inertia_kg_m2 = [{i[0][0]!r}, {i[1][1]!r}, {i[2][2]!r}]\n"
        f"products_kg_m2 = [{i[0][1]!r}, {i[0][2]!r}, {i[1][2]!r}]\n"
        f"hinge_m = {p['r_HB_B']}\naxis = {h[1].tolist()}\ncg_offset_m = {offset}\n"
        f"frequency_hz = {pm.PANEL_HZ}\ndamping_ratio = {pm.PANEL_ZETA}\n"
    )
    return _file(pm, p["mass_kg"], np.add(p["r_HB_B"], offset), own, block)


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
    path.write_text(_slosh(peer) if scenario == "slosh" else _panel(peer), encoding="utf-8")
    mine = _response(Vehicle.load(path).flight_model)
    theirs = _response(peer.build_scenario(scenario, peer.PARAMS, 0.01))
    moving = np.abs(theirs).max(axis=0) > 0  # the planar scenarios leave roll and pitch at 0
    error = np.abs(mine - theirs).max(axis=0)[moving] / np.abs(theirs).max(axis=0)[moving]
    assert moving.sum() >= 3 and error.max() < tolerance
    # and what stays still in the peer's stays still in rcsim's (to the same relative bound)
    assert np.abs(mine[:, ~moving]).max(initial=0.0) <= tolerance * np.abs(theirs).max()
