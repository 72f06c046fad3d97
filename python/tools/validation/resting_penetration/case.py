"""Resting penetration: a 1 m tube lying on a plane.

Reference: S spheres of penalty stiffness k share the weight: each sinks m g / ((S - 1) k).
Convergence: 20, 40, 80 control points.
"""

from __future__ import annotations

import numpy as np

from validation.common import DENSITY, G, RADIUS, relax

def resting_penetration(n: int, **keys) -> dict:
    """A 1 m tube lying on a plane: the interior spheres' penetration against the penalty's
    m g / ((S - 1) k) (S spheres of stiffness k share the weight). `keys`: further intestine keys
    (resolution: tolerance, ...), winning over the case's."""
    config = dict(length=1.0, control_points=n, damping=5, shape="line", start=[0, 0, 0.1], direction=[1, 0, 0])
    config.update(keys)
    data, gut, cost = relax(config, 3.0, 0.001, worldbody='<geom type="plane" size="3 3 0.1"/>')
    penetration = gut.radius - gut.sphere_centres(data)[:, 2]
    weight = DENSITY * np.pi * RADIUS**2 * 1.0 * G
    reference = weight / ((gut.sphere_count - 1) * 2000.0)  # default contact_stiffness, N/m
    return {"value": float(np.median(penetration[gut.sphere_count // 8:-gut.sphere_count // 8])),
            "reference": reference, "unit": "m", "wall_s_per_sim_s": cost,
            "fraction_of_radius": float(penetration.max() / gut.radius)}


CASES = {"resting_penetration": (resting_penetration, (20, 40, 80))}
