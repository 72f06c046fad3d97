"""Free vibration: the weightless tip-load cantilever ringing undamped from a kick on its outer quarter.

Reference: (beta L)^2 sqrt(EI / (mu L^4)) / (2 pi), beta L = 1.87510, 4.69409 (modes 1 and 2).
Convergence: 8, 16, 32 control points.
"""

from __future__ import annotations

import functools
import time

import mujoco
import numpy as np

from validation.common import (BETA_L, DENSITY, MU, RADIUS, SECOND_MOMENT, TIP_LENGTH, TIP_RIGIDITY, compile_rod,
                               peak_frequency, rk4_substeps)

@functools.lru_cache(maxsize=None)
def vibration_run(n: int, **keys) -> tuple[float, float, float]:
    """Free vibration of the weightless tip-load cantilever, undamped, from a kick on its outer
    quarter: the first two frequencies (Hz) and the wall s per sim s. `keys`: further intestine
    keys (resolution: samples_per_segment, ...), winning over the case's."""
    length, rigidity = TIP_LENGTH, TIP_RIGIDITY
    young = rigidity / SECOND_MOMENT
    first = BETA_L[0]**2 * np.sqrt(rigidity / (MU * length**4)) / (2 * np.pi)
    substeps = rk4_substeps(n, length, rigidity, young * np.pi * RADIUS**2)
    config = dict(length=length, control_points=n, radius=RADIUS, density=DENSITY, young_modulus=young, damping=0,
                  substeps=substeps, self_collision=0, shape="line", direction=[1, 0, 0], clamped="start")
    config.update(keys)
    model, data, gut = compile_rod(config, 1e-3, gravity=(0, 0, 0))
    velocities = gut.velocities(data)
    velocities[int(0.75 * len(velocities)):, 2] = 1e-3  # m/s: deflections stay ~1e-4 L, linear
    steps = int(round(30.0 / first / 1e-3))  # 30 periods of the first mode
    tip = np.empty(steps)
    start = time.perf_counter()
    for i in range(steps):
        mujoco.mj_step(model, data)
        tip[i] = gut.positions(data)[-1, 2]
    cost = (time.perf_counter() - start) / (steps * 1e-3)
    ratio = (BETA_L[1] / BETA_L[0])**2
    return (peak_frequency(tip, 1e-3, 0.5 * first, 1.5 * first),
            peak_frequency(tip, 1e-3, 0.5 * ratio * first, 1.5 * ratio * first), cost)


def vibration(n: int, mode: int, **keys) -> dict:
    rigidity, length = TIP_RIGIDITY, TIP_LENGTH
    reference = BETA_L[mode - 1]**2 * np.sqrt(rigidity / (MU * length**4)) / (2 * np.pi)
    frequencies = vibration_run(n, **keys)
    return {"value": frequencies[mode - 1], "reference": reference, "unit": "Hz", "wall_s_per_sim_s": frequencies[2]}


CASES = {f"vibration_mode_{mode}": (functools.partial(vibration, mode=mode), (8, 16, 32)) for mode in (1, 2)}
