"""Catenary: 4 m of the paper's springs with a stiff global length term, ends pinned 3 m apart.

Reference: the sag a (cosh(D / 2a) - 1) = 1.177335 m, a = 1.110084 m (D = 3 m, L = 4 m).
Convergence: 25, 50, 100, 200 control points.
"""

from __future__ import annotations

import numpy as np

from validation.common import relax

CATENARY_SAG = 1.177335  # m: L = 4 m, ends 3 m apart, a = 1.110084 m


def catenary(n: int, integrator: str | None = "rk4", timestep: float = 0.001, substeps: int | None = 2,
             stretch_stiffness: float = 100.0, **keys) -> dict:
    """`integrator` and `substeps` None: the plugin's. `keys`: further intestine keys (resolution: samples_per_segment, ...), winning over the case's."""
    depth = np.sqrt(2.0**2 - 1.5**2)  # a V of the rod's length
    config = dict(length=4, control_points=n, stretch_stiffness=stretch_stiffness, bend_stiffness=0,
                  global_stretch_stiffness=5000, damping=4, substeps=substeps, integrator=integrator,
                  divergence_retries=0, self_collision=0, shape="polyline",
                  points=[-1.5, 0, 0, 0, 0, -depth, 1.5, 0, 0], pinned=[0, -1])
    config.update(keys)
    data, gut, cost = relax(config, 6.0, timestep)
    sag = -gut.axis_points(data, 20001)[:, 2].min()
    return {"value": sag, "reference": CATENARY_SAG, "unit": "m", "wall_s_per_sim_s": cost}


CASES = {"catenary": (catenary, (25, 50, 100, 200))}
