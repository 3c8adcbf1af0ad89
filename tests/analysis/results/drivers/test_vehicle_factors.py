"""Authority factors of a vehicle file's campaign come from that vehicle's jet matrix.

Oracles: (1) the paper's vehicle file gives exactly the packaged vehicle's factors (its torque
signs are Table 2); (2) on the canted-quad (16 jets) and canted-triad (12 jets) vehicles with
no dispersion, the +roll authority is the sum of the +roll jets' roll torques over Ixx, both
from the vehicle file (``VehicleDef.force_torque``, its tensor's xx entry), to 1e-12 relative
(rounding only).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from rcsim.analysis.engine.runs_table import input_frame
from rcsim.analysis.results.drivers.factors import physics_factors
from rcsim.models.tables import load_dispersions
from rcsim.spacecraft.dispersions import DispersionSigmas, draw_runs
from rcsim.spacecraft.vehicle import Vehicle

#: The paper's vehicle (paper.toml).
PAPER = Vehicle.load()


def _runs(flying, sigmas, n=8):
    return input_frame(draw_runs(flying.nominal(1), sigmas, 3, np.arange(n)))


def test_paper_vehicle_file_gives_the_packaged_factors():
    sig = DispersionSigmas.from_table(load_dispersions())
    runs = _runs(Vehicle.load("paper"), sig)
    pd.testing.assert_frame_equal(
        physics_factors(runs, PAPER), physics_factors(runs, Vehicle.load("paper"))
    )


@pytest.mark.parametrize("name", ["canted16", "canted12"])
def test_canted_authority_from_the_jet_matrix(name):
    flying = Vehicle.load(name)
    runs = _runs(flying, DispersionSigmas(), n=2)
    factors = physics_factors(runs, Vehicle.load(name))
    torque = flying.force_torque()[3:]  # (3, n_jets) about the CG [N m]
    roll = torque[0]
    # Ixx: the file's tensor entry about body x (not MuJoCo's first principal moment, about
    # an axis 4 deg off x: 0.08 % larger)
    ixx = flying.definition.inertia_kg_m2[0, 0]
    expect = roll[roll > 1e-9 * np.abs(roll).max()].sum()
    got = factors["authority_roll_pos_rad_s2"].to_numpy() * ixx
    np.testing.assert_allclose(got, expect, rtol=1e-12)


def test_imbalance_only_for_pairs():
    """Issue 18 review: the imbalance factor is a pair's (Table 2: each axis direction has
    exactly two jets).  Oracle: on the paper's vehicle it is the thrust of the pair's first
    jet minus its second, jets from Table 2 (``rcsim/models/data/table2_jet_map.csv``), exactly;
    canted16's and canted12's groups have 4-8 jets (their own torque signs), so they have
    none."""
    from rcsim.models.tables import load_jet_map

    sig = DispersionSigmas.from_table(load_dispersions())
    runs = _runs(Vehicle.load("paper"), sig)
    factors = physics_factors(runs, Vehicle.load("paper"))
    jet_map = load_jet_map()
    for a, axis in enumerate(("roll", "pitch", "yaw")):
        for sign, d in ((1, "pos"), (-1, "neg")):
            first, second = np.flatnonzero(jet_map[:, a] == sign)
            expect = runs[f"jet_{first + 1:02d}_thrust_n"] - runs[f"jet_{second + 1:02d}_thrust_n"]
            np.testing.assert_array_equal(factors[f"imbalance_{axis}_{d}_n"], expect)
    for name in ("canted16", "canted12"):
        flying = Vehicle.load(name)
        canted = physics_factors(_runs(flying, DispersionSigmas(), n=2), Vehicle.load(name))
        assert "authority_roll_pos_rad_s2" in canted
        assert not [c for c in canted if c.startswith("imbalance_")]


def test_report_explains_imbalance_only_when_it_is_there():
    """The report's method text describes the pairs' imbalance where the factor exists and
    says why there is none otherwise (not 'the thrust difference of its two jets' of a
    six-jet group)."""
    from types import SimpleNamespace

    from rcsim.analysis.results.drivers.report_sections import _imbalance_text

    def res(inputs):
        return SimpleNamespace(runset=SimpleNamespace(derived_inputs=inputs))

    assert "exactly two jets" in _imbalance_text(res(["imbalance_roll_pos_n"]))
    text = _imbalance_text(res(["authority_roll_pos_rad_s2"]))
    assert "no imbalance_* factor" in text and "two jets" not in text
