"""Cantilever: 0.5 m, clamped="start", under its own weight, EI from young_modulus.

Reference: the tip deflection w L^4 / (8 EI), small (1 % of L).
Convergence: 8, 16, 32, 48 control points.
"""

from __future__ import annotations

from validation.common import DENSITY, G, MU, RADIUS, SECOND_MOMENT, relax

def cantilever(n: int, integrator: str = "rk4", timestep: float = 0.001, substeps: int | None = None, **keys) -> dict:
    """0.5 m clamped (config clamped="start") under its own weight, EI for a 1 % tip deflection.
    `substeps` per `timestep` (s); by default (None) the plugin's choice. `keys`: further
    intestine keys (resolution: samples_per_segment, ...), winning over the case's."""
    length, tip_fraction = 0.5, 0.01
    rigidity = MU * G * length**4 / (8.0 * tip_fraction * length)
    # the axis barely stretches here: a softer EA (raw stiffness wins) keeps the step affordable
    config = dict(length=length, control_points=n, radius=RADIUS, density=DENSITY,
                  young_modulus=rigidity / SECOND_MOMENT, stretch_stiffness=2000, damping=30, substeps=substeps,
                  integrator=integrator, divergence_retries=0, self_collision=0, shape="line", direction=[1, 0, 0],
                  clamped="start")
    config.update(keys)
    data, gut, cost = relax(config, 0.6, timestep)
    tip = gut.axis_points(data, 2)[-1]
    return {"value": -tip[2], "reference": MU * G * length**4 / (8.0 * rigidity), "unit": "m",
            "wall_s_per_sim_s": cost, "substeps": gut.stability()["substeps"]}


CASES = {"cantilever": (cantilever, (8, 16, 32, 48))}
