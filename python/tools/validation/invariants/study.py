"""Invariants: the energy drift against the step (its order in dt, RK4), and the length of a
hanging intestine with and without the paper's global length term.
"""

from __future__ import annotations

import time

import mujoco
import numpy as np
from tqdm import tqdm

from validation.common import compile_rod, relax


def energy_drift(step: float, duration: float = 1.0) -> dict:
    """A 1 m rod (E = 1e5 Pa, EI and EA) bent into half a sine wave of 5 cm and released without
    gravity, damping or contact: the largest relative change of its total energy over `duration`
    s at the RK4 step `step` (s, one substep per MuJoCo step)."""
    config = dict(length=1.0, control_points=25, young_modulus=1e5, damping=0, substeps=1, self_collision=0,
                  shape="line", direction=[1, 0, 0], integrator="rk4")
    model, data, gut = compile_rod(config, step, gravity=(0, 0, 0))
    positions = gut.positions(data)
    positions[:, 2] = 0.05 * np.sin(np.pi * positions[:, 0])
    start_energy = sum(gut.energy(data).values())
    worst, steps = 0.0, int(round(duration / step))
    start = time.perf_counter()
    for i in range(steps):
        mujoco.mj_step(model, data)
        if i % max(1, steps // 50) == 0 or i == steps - 1:
            worst = max(worst, abs(sum(gut.energy(data).values()) / start_energy - 1.0))
    return {"step_s": step, "relative_energy_drift": worst, "diverged": gut.divergence_count(data) > 0,
            "wall_s_per_sim_s": (time.perf_counter() - start) / duration}


def energy_drift_order(quick: bool = False) -> dict:
    """Energy drift at halving steps and the observed order. RK4 loses (omega h)^6 / 72 of an
    oscillation's energy per step, so over a fixed time its drift is O(h^5), one order better
    than its phase error."""
    steps = (4e-4, 2e-4, 1e-4) if quick else (8e-4, 4e-4, 2e-4, 1e-4)
    rows = [energy_drift(h) for h in tqdm(steps, desc="energy drift", leave=False)]
    a, b = rows[-2], rows[-1]
    order = float(np.log(a["relative_energy_drift"] / b["relative_energy_drift"]) / np.log(a["step_s"] / b["step_s"]))
    return {"integrator": "rk4", "rows": rows, "order_in_dt": order}


def length_preservation() -> dict:
    """The default 4 m intestine (the paper's springs) hanging from one end, at rest: its
    relative stretch with the global length term (default 200 N/m) and without it."""
    out = {}
    for label, global_stiffness in (("with_global_stretch", 200.0), ("without_global_stretch", 0.0)):
        config = dict(length=4.0, control_points=50, damping=5, substeps=2, self_collision=0, shape="line",
                      direction=[0, 0, -1], pinned=[0], global_stretch_stiffness=global_stiffness)
        data, gut, cost = relax(config, 6.0, 0.001)
        out[label] = {"relative_stretch": gut.length(data) / 4.0 - 1.0, "global_stretch_stiffness": global_stiffness,
                      "wall_s_per_sim_s": cost}
    return out
