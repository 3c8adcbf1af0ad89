"""A vehicle file's ``[pulse]`` and ``[propellant.blowdown]``: what they read to, and the
warnings they earn (docs/vehicles.md, "Pulses", "Blowdown", "Warnings").  Refusals are the
bad-input corpus's (tests/analysis/apps/cli/corpus/vehicle.toml)."""

from __future__ import annotations

import numpy as np

from rcsim.spacecraft.vehicle.definition import packaged_vehicle
from rcsim.spacecraft.vehicle.vehicle import Vehicle


def load(tmp_path, extra: str, *, min_on_s: float = 0.0, propellant: bool = False) -> Vehicle:
    text = packaged_vehicle("paper").read_text(encoding="utf-8")
    text = text.replace("min_on_s = 0.0 ", f"min_on_s = {min_on_s} ", 1)
    if propellant:
        text = text.replace("[propellant]\n", "[propellant]\nmass_kg = 40.0\n", 1)
    path = tmp_path / "v.toml"
    path.write_text(text + extra, encoding="utf-8")
    return Vehicle.load(str(path))


def test_jet_overrides_its_rise_and_tail(tmp_path):
    """A ``[[jet]] pulse = {...}`` sets that jet's values; the others keep ``[pulse]``'s."""
    text = packaged_vehicle("paper").read_text(encoding="utf-8")
    text = text.replace(
        'name = "jet_02"\n', 'name = "jet_02"\npulse = { rise_s = 0.02, tail_s = 0.001 }\n', 1
    )
    path = tmp_path / "v.toml"
    path.write_text(text + '\n[pulse]\nmodel = "exponential"\nrise_s = 0.005\n', encoding="utf-8")
    shape = Vehicle.load(str(path)).pulse_shape(2)
    assert shape is not None and shape.rise_s.shape == (2, 16)
    np.testing.assert_array_equal(shape.rise_s[:, 1], 0.02)
    np.testing.assert_array_equal(shape.tail_s[:, 1], 0.001)
    assert (np.delete(shape.rise_s, 1, axis=1) == 0.005).all()
    assert (np.delete(shape.tail_s, 1, axis=1) == 0.0).all()


def test_blowdown_reads_its_defaults(tmp_path):
    """Exponents default to 1 (thrust) and 0 (Isp), the reference pressure to P0."""
    v = load(
        tmp_path,
        "\n[propellant.blowdown]\ngas_volume_m3 = 0.02\npressure_pa = 2.2e6\n"
        "density_kg_m3 = 1004.0\n",
        propellant=True,
    )
    b = v.blowdown(3)
    assert b is not None
    assert (b.polytropic_n, b.thrust_exponent, b.isp_exponent) == (1.0, 1.0, 0.0)
    assert b.reference_pa == 2.2e6 and b.pressure_pa.tolist() == [2.2e6] * 3
    assert b.thrust_factor(np.zeros(3)).tolist() == [1.0] * 3


def test_slow_rise_against_the_minimum_pulse_warns(tmp_path):
    """A 10 ms minimum pulse on a 20 ms linear rise delivers u^2 / (2 r) + tail = 2.5 ms of
    full thrust (tail 0), a quarter of the square pulse's: below the 50 % rule."""
    v = load(tmp_path, '\n[pulse]\nmodel = "linear"\nrise_s = 0.02\n', min_on_s=0.01)
    assert any("25 % of a square pulse" in w for w in v.warnings())
    quick = load(tmp_path, '\n[pulse]\nmodel = "linear"\nrise_s = 0.002\n', min_on_s=0.01)
    assert not any("square pulse" in w for w in quick.warnings())


def test_deep_blowdown_warns(tmp_path):
    """40 kg of hydrazine (39.8 L) on 5 L of gas, isothermal: P falls to 5 / 44.8 = 11 %."""
    v = load(
        tmp_path,
        "\n[propellant.blowdown]\ngas_volume_m3 = 0.005\npressure_pa = 2.2e6\n"
        "density_kg_m3 = 1004.0\n",
        propellant=True,
    )
    assert any("falls to 11.2 % of nominal" in w for w in v.warnings())
