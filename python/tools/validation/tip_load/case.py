"""Tip-loaded cantilever: 0.5 m, EI = 1 N m^2, weightless, a dead tip load P = alpha EI / L^2 hung on a
grasper (the whole stack: site, jaw joint, hold spring).

Reference: deflection / L = alpha / 3 at alpha = 0.03 (linear), then the inextensible elastica's
0.30172, 0.49346, 0.71379, 0.81061 at alpha = 1, 2, 5, 10.
Convergence: 8, 16, 32 control points.
"""

from __future__ import annotations

import functools

import numpy as np

from validation.common import DENSITY, MU, RADIUS, SECOND_MOMENT, TIP_LENGTH, TIP_RIGIDITY, relax, rk4_substeps

# Elastica, inextensible, dead vertical tip load: vertical tip deflection / L against alpha = P L^2 / EI.
ELASTICA = {1.0: 0.30172, 2.0: 0.49346, 5.0: 0.71379, 10.0: 0.81061}
GRASP_STIFFNESS = 2.0e4  # N/m: the hook holding the load stretches P / k (2 mm at 40 N)


def tip_load(n: int, alpha: float, **keys) -> dict:
    """A free body hooked to the tip by a grasper (the whole stack: site, jaw joint, hold
    spring) and pushed down by a constant xfrc_applied P = alpha EI / L^2 (a dead load).
    Reference: alpha / 3 (linear) below alpha = 0.1, else the elastica table. `keys`: further
    intestine keys (resolution: samples_per_segment, ...), winning over the case's."""
    length, rigidity = TIP_LENGTH, TIP_RIGIDITY
    young = rigidity / SECOND_MOMENT
    axial = young * np.pi * RADIUS**2
    load = alpha * rigidity / length**2
    tip_mass = MU * length / (n - 1) / 3.0  # about the consistent mass at the end control point
    substeps = rk4_substeps(n, length, rigidity, axial, np.sqrt(GRASP_STIFFNESS / tip_mass))
    config = dict(length=length, control_points=n, radius=RADIUS, density=DENSITY, young_modulus=young, damping=30,
                  substeps=substeps, self_collision=0, shape="line", direction=[1, 0, 0], clamped="start",
                  grasp_sites="hook", grasp_joints="jaw", grasp_stiffness=GRASP_STIFFNESS, grasp_damping=2,
                  grasp_slip_force=1e9)
    config.update(keys)
    # the load: 1 kg on slide joints (no rotation to settle), damped about critically on the
    # beam's tip stiffness 3 EI / L^3; the jaw is a hinge nothing turns, so it never opens.
    # (A 0.1 kg load oscillated and grew: the hold's force reaches MuJoCo once per step.)
    worldbody = (f'<body name="load" pos="{length} 0 0">'
                 '<joint type="slide" axis="1 0 0" damping="10"/><joint type="slide" axis="0 1 0" damping="10"/>'
                 '<joint type="slide" axis="0 0 1" damping="10"/>'
                 '<geom type="sphere" size="0.005" mass="1" contype="0" conaffinity="0"/><site name="hook"/>'
                 '<body name="jaw"><joint name="jaw" type="hinge" axis="1 0 0"/>'
                 '<geom type="sphere" size="0.002" mass="0.001" contype="0" conaffinity="0"/></body></body>')

    def hang(model, data):
        data.xfrc_applied[model.body("load").id, 2] = -load

    data, gut, cost = relax(config, 4.0, 0.001, gravity=(0, 0, 0), worldbody=worldbody, setup=hang)
    if gut.grasps(data)[0].status != "holding":
        raise RuntimeError("the hook let go of the tip")
    deflection = -gut.axis_points(data, 2)[-1][2] / length
    reference = alpha / 3.0 if alpha < 0.1 else ELASTICA[alpha]
    return {"value": deflection, "reference": reference, "unit": "L", "wall_s_per_sim_s": cost,
            "substeps": substeps, "load_N": load, "axial_strain": load / axial}


CASES = {"tip_load": (functools.partial(tip_load, alpha=0.03), (8, 16, 32)),
         **{f"elastica_alpha_{alpha:g}": (functools.partial(tip_load, alpha=alpha), (8, 16, 32))
            for alpha in ELASTICA}}
