"""Pile overlap: the 4 m intestine dropped into a pile on a plane for 5 s.

Reference: no overlap (0) between non-neighbouring parts of the tube; measured as a fraction of
the diameter. Convergence: 125, 250 control points.
"""

from __future__ import annotations

import numpy as np

from validation.common import relax

def pile_overlap(n: int) -> dict:
    """The 4 m intestine dropped into a pile on a plane, 5 s: the deepest overlap of two
    non-neighbouring parts of the tube, as a fraction of its diameter (reference: none)."""
    config = dict(length=4, control_points=n, shape="serpentine", box=[-0.1, -0.1, 0.05, 0.1, 0.1, 0.8])
    data, gut, cost = relax(config, 5.0, 0.002, worldbody='<geom type="plane" size="2 2 .1"/>')
    count = 2 * (gut.sphere_count - 1) + 1
    x = gut.axis_points(data, count)
    arc = np.linspace(0.0, gut.rest_length, count)
    closest = np.inf
    for i in range(0, count, 64):  # blocks: the full distance matrix would be 400 MB at n = 1000
        d = np.linalg.norm(x[i:i + 64, None, :] - x[None, :, :], axis=-1)
        far = np.abs(arc[i:i + 64, None] - arc[None, :]) >= np.pi * gut.radius
        closest = min(closest, d[far].min())
    overlap = max(0.0, 2 * gut.radius - closest) / (2 * gut.radius)
    return {"value": overlap, "reference": 0.0, "unit": "diameter", "wall_s_per_sim_s": cost,
            "absolute_error": True, "top_m": float(x[:, 2].max())}


CASES = {"pile_overlap": (pile_overlap, (125, 250))}
