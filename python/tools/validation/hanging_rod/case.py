"""Hanging rod: 1 m of a solid tube of E = 1e5 Pa hanging from its top.

Reference: the stretch mu g L^2 / (2 EA) (the springs carry EA = E pi r^2).
Convergence: 10, 20, 40, 80 control points.
"""

from __future__ import annotations

import numpy as np

from validation.common import DENSITY, G, MU, RADIUS, relax

def hanging_rod(n: int, **keys) -> dict:
    """`keys`: further intestine keys (resolution: samples_per_segment, ...), winning over the case's."""
    young, length = 1.0e5, 1.0
    area = np.pi * RADIUS**2
    config = dict(length=length, control_points=n, radius=RADIUS, density=DENSITY, young_modulus=young, damping=6,
                  substeps=2, self_collision=0, shape="line", direction=[0, 0, -1], pinned=[0])
    config.update(keys)
    data, gut, cost = relax(config, 5.0, 0.001)
    reference = MU * G * length**2 / (2.0 * young * area)
    return {"value": gut.length(data) - length, "reference": reference, "unit": "m", "wall_s_per_sim_s": cost}


CASES = {"hanging_rod": (hanging_rod, (10, 20, 40, 80))}
