"""The flown inputs read back from MuJoCo's per-run model (issue 9), and the per-run seeding rule.

Oracles
-------
* The draw (rcsim.spacecraft.dispersions.draw_runs) is what each run must fly.  BatchSimulation
  writes it into MuJoCo's per-simulation model fields and runs mj_setConst; the values read back
  must equal the draw *exactly* (tolerance 0): they are float64 copies, and mj_setConst takes
  ``body_mass``, ``body_ipos``, ``body_iquat``, ``body_inertia`` and ``actuator_gear`` as inputs
  (``mujoco.MjModel._setconst_inputs``), so it re-orients and re-diagonalizes nothing.
* A run with invalid parameters is flown with the nominal vehicle (and reported failed), so
  that is what reads back.
* Seeding (developers' guide): run i draws from ``SeedSequence(seed, spawn_key=(i,))``, spawned
  (dispersion, noise).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from rcsim.analysis.engine.runs_table import PRODUCT_NAMES, input_frame
from rcsim.lookup.open_loop import OpenLoopController
from rcsim.models.tables import PAPER_CYCLE_S, load_dispersions
from rcsim.spacecraft.dispersions import (
    DispersionSigmas,
    draw_runs,
    mass_extra_draws,
    run_generators,
)
from rcsim.spacecraft.navigation import Guidance
from rcsim.spacecraft.simulation import BatchSimulation
from rcsim.spacecraft.vehicle.model import BODY
from rcsim.spacecraft.vehicle.run_parameters import RunParameters

FIELDS = ("mass_kg", "cg_B", "inertia_B", "thrust_n", "jet_dir_S")


@pytest.fixture(scope="module")
def dispersed(paper):
    # 3x Table 5 (the stress campaigns of Figs 13-14): every field differs from nominal.
    sigmas = DispersionSigmas.from_table(load_dispersions(), scale=3.0)
    return draw_runs(paper.nominal(1), sigmas, seed=2024, run_ids=np.arange(7, 19))


def test_flown_params_equal_the_draw_exactly(paper, dispersed):
    sim = BatchSimulation(dispersed.params, vehicle=paper, nthread=1)
    flown = sim.flown_params()
    for name in FIELDS:
        np.testing.assert_array_equal(
            getattr(flown, name), getattr(dispersed.params, name), err_msg=name
        )
    assert flown.isp_s == dispersed.params.isp_s
    # The read-back is a copy, not a view of the simulator's memory.
    flown.mass_kg[:] = 0.0
    assert np.all(sim.flown_params().mass_kg > 0)
    # Principal axes stay the body axes: body_iquat is the identity in every run.
    iquat = sim.physics.batch.expanded("body_iquat")
    iquat = paper.model.body_iquat[None] if iquat is None else iquat
    np.testing.assert_array_equal(iquat[:, paper.model.body(BODY).id], [[1.0, 0.0, 0.0, 0.0]])


def test_history_carries_the_flown_params(paper, dispersed):
    """The history of a flight records what was flown; an invalid run reads back nominal."""
    params = dispersed.params.take(slice(0, 3))
    mass = params.mass_kg.copy()
    mass[1] = np.nan
    params = RunParameters(
        mass_kg=mass,
        cg_B=params.cg_B,
        inertia_B=params.inertia_B,
        thrust_n=params.thrust_n,
        jet_dir_S=params.jet_dir_S,
        isp_s=params.isp_s,
    )
    hist = BatchSimulation(params, vehicle=paper, nthread=1).run(
        OpenLoopController(np.zeros(16), PAPER_CYCLE_S), Guidance.attitude(np.zeros((3, 3))), 0.2
    )
    assert hist.failed.tolist() == [False, True, False]
    nominal = paper.nominal(1)
    for name in FIELDS:
        got, drawn = getattr(hist.flown_params, name), getattr(params, name)
        np.testing.assert_array_equal(got[[0, 2]], drawn[[0, 2]], err_msg=name)
        np.testing.assert_array_equal(got[1], getattr(nominal, name)[0], err_msg=name)


def test_run_generators_follow_the_seeding_rule():
    for seed, run_id in ((0, 0), (5, 9), (2**40, 123456)):
        first, second = run_generators(seed, run_id)
        expected = np.random.SeedSequence(seed, spawn_key=(run_id,)).spawn(2)
        for got, seq in zip((first, second), expected):
            np.testing.assert_array_equal(got.random(4), np.random.default_rng(seq).random(4))


def test_flown_cg_and_principal_frames_equal_the_draw_exactly(paper):
    """Issue 18: with CG y/z and products of inertia dispersed, each run has its own CG
    (``body_ipos``) and principal frame (``body_iquat``, an input of mj_setConst like the
    moments): read back, they equal the draw exactly.  The recorded inputs
    (:func:`rcsim.analysis.engine.runs_table.input_frame`) are the tensor in B rebuilt from them,
    equal to the drawn tensor (the nominal moments plus the drawn products) to 1e-12 of the
    largest moment: the eigen round trip's rounding."""
    sigmas = replace(
        DispersionSigmas.from_table(load_dispersions(), scale=3.0),
        cg_y_m=0.01,
        cg_z_m=0.01,
        products_kg_m2=(20.0, 30.0, 40.0),
    )
    drawn = draw_runs(paper.nominal(1), sigmas, seed=2024, run_ids=np.arange(7, 19))
    sim = BatchSimulation(drawn.params, vehicle=paper, nthread=1)
    flown = sim.flown_params()
    for name in (*FIELDS, "iquat"):
        np.testing.assert_array_equal(
            getattr(flown, name), getattr(drawn.params, name), err_msg=name
        )
    assert np.all(drawn.params.cg_B[:, 1:] != 0.0)
    # The drawn tensor, rebuilt independently: Table 5's moments on the diagonal (the paper's
    # principal axes are B) and the products off it, from the same standard normals.
    moments_only = draw_runs(
        paper.nominal(1),
        DispersionSigmas(inertia_kg_m2=sigmas.inertia_kg_m2),
        seed=2024,
        run_ids=np.arange(7, 19),
    ).params.inertia_B
    x = mass_extra_draws(2024, np.arange(7, 19))
    frame = input_frame(replace(drawn, params=flown))
    scale = 1e-12 * moments_only.max()
    for a, col in enumerate(("ixx_kg_m2", "iyy_kg_m2", "izz_kg_m2")):
        np.testing.assert_allclose(frame[col], moments_only[:, a], rtol=0, atol=scale)
    for k, col in enumerate(PRODUCT_NAMES):
        np.testing.assert_allclose(
            frame[col], sigmas.products_kg_m2[k] * x[:, 2 + k], rtol=0, atol=scale
        )
