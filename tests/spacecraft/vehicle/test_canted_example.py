"""The canted examples are what their documented arithmetic says (rcsim/models/vehicle/README.md,
"The canted-quad example" and "The canted-triad example"): each jet's direction recomputed
from the formulas, and every jet torquing at least two axes with some force.  Tolerance 1e-14:
the files hold the directions to 15 significant digits."""

from __future__ import annotations

import numpy as np
import pytest

from rcsim.spacecraft.vehicle import load_vehicle
from rcsim.spacecraft.vehicle.mjcf import force_torque


def test_directions_follow_the_arithmetic():
    vehicle = load_vehicle("canted16")
    cant = np.radians(10.0)
    k = 0
    for phi_deg in (45.0, 135.0, 225.0, 315.0):
        phi = np.radians(phi_deg)
        radial = np.array([0.0, np.cos(phi), np.sin(phi)])
        tangent = np.array([0.0, -np.sin(phi), np.cos(phi)])
        corner = (2.41, 0.9 * np.sign(np.cos(phi)), 0.9 * np.sign(np.sin(phi)))
        for d0 in (np.array([1.0, 0, 0]), np.array([-1.0, 0, 0]), tangent, -tangent):
            d = np.cos(cant) * d0 - np.sin(cant) * radial
            jet = vehicle.jets[k]
            np.testing.assert_allclose(jet.direction, d / np.linalg.norm(d), atol=1e-14)
            np.testing.assert_allclose(jet.position_m, corner, atol=0)
            k += 1
    assert k == vehicle.n_jets == 16


def test_triad_directions_follow_the_arithmetic():
    """canted12: the quads' ring and cant, one axial jet per corner (+x at A and C, -x at B
    and D) and the two tangential jets, in that order."""
    vehicle = load_vehicle("canted12")
    cant = np.radians(10.0)
    k = 0
    for phi_deg, axial in ((45.0, 1.0), (135.0, -1.0), (225.0, 1.0), (315.0, -1.0)):
        phi = np.radians(phi_deg)
        radial = np.array([0.0, np.cos(phi), np.sin(phi)])
        tangent = np.array([0.0, -np.sin(phi), np.cos(phi)])
        corner = (2.41, 0.9 * np.sign(np.cos(phi)), 0.9 * np.sign(np.sin(phi)))
        for d0 in (np.array([axial, 0, 0]), tangent, -tangent):
            d = np.cos(cant) * d0 - np.sin(cant) * radial
            jet = vehicle.jets[k]
            np.testing.assert_allclose(jet.direction, d / np.linalg.norm(d), atol=1e-14)
            np.testing.assert_allclose(jet.position_m, corner, atol=0)
            k += 1
    assert k == vehicle.n_jets == 12


@pytest.mark.parametrize("name", ["canted16", "canted12"])
def test_every_jet_couples_two_or_three_axes_and_pushes(name):
    ft = force_torque(load_vehicle(name))
    torque, force = ft[3:], ft[:3]
    axes = (np.abs(torque) > 1e-9 * np.abs(torque).max()).sum(axis=0)
    assert axes.min() >= 2
    assert (np.linalg.norm(force, axis=0) > 1.0).all()  # N; each jet pushes
