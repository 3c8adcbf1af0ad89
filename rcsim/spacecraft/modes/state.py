"""The whole vehicle's state when the hub carries modes: what the hub's free joint alone does
not say."""

from __future__ import annotations

import mujoco
import numpy as np
from mujoco.batch import Batch


def subtree_velocity_N(batch: Batch, hub: int) -> np.ndarray:
    """Velocity of each simulation's whole-vehicle CG (hub and modes) in N [m/s], (nsim, 3).

    MuJoCo's ``subtree_linvel`` of the hub (``mj_subtreeVel`` after ``mj_forward``), run on
    each simulation's own model and state: a loop over the runs, called at a flight's start
    and end only (a delta-v), never per cycle.
    """
    out = np.empty((batch.nsim, 3))
    model = data = None
    for i in range(batch.nsim):
        model = batch.get_model(i, model)
        data = batch.get_data(i, data)
        mujoco.mj_forward(model, data)
        mujoco.mj_subtreeVel(model, data)
        out[i] = data.subtree_linvel[hub]
    return out
