"""Fixtures shared across test packages."""
import mujoco
import pytest

from rcsim.models.tables import load_mass_properties
from rcsim.spacecraft.vehicle import load_model


@pytest.fixture(scope="module")
def model() -> mujoco.MjModel:
    """The packaged vehicle at its default physics settings."""
    return load_model()


@pytest.fixture(scope="module")
def table1():
    """Gambone Table 1 mass properties (SI)."""
    return load_mass_properties()
