"""Grasp-pull slip, against the organ: how hard the jaws must pinch the small bowel to pull it.

Experiment (Heijnsdijk, de Visser, Dankelman, Gouma: Slip and damage properties of jejunum and
colon, Surg Endosc 17:1427-1430, 2003; Heijnsdijk et al., Surg Endosc 18:980-985, 2004): pig
small bowel, held at one end, grasped at the other by laparoscopic jaws closed at a set pinch
and pulled until it slips. A pull of 5 N needed a pinch of 3.0 +- 0.4 N.

Here: a 15 cm bowel segment (the tasks' radius and material), clamped at its start; a grasper
whose hinge jaw is closed by a position actuator at a command that gives the chosen pinch
(kp (closed - command) / lever), on a carriage pulled away along the axis at 2 cm/s. The pull
is the hold's reaction on the carriage; the slip, the step the plugin lets go.

Model: a hold slips once it pulls harder than 2 mu P (two jaw faces, mu `grasp_friction`),
capped by `grasp_slip_force`. The case measures the whole chain (the actuator's squeeze, the
lever, the friction, the hold spring's reaction), not the formula.

    python python/tools/validation/organ/grasp_slip.py   # writes docs/validation/organ.json and the chart
"""

from __future__ import annotations

import pathlib
import sys

import mujoco
import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[2]))  # python/tools, run as a script

from validation.common import compile_rod  # noqa: E402

HEIJNSDIJK_PULL_N = 5.0
HEIJNSDIJK_PINCH_N = 3.0     # needed for that pull, +- 0.4 N (sd)
HEIJNSDIJK_PINCH_SD_N = 0.4
PINCHES_N = (1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0)
LENGTH_M = 0.15
RADIUS_M = 0.0125            # the tasks' bowel
JAW_KP = 0.5                 # N m/rad, the tasks' grasper jaw
LEVER_M = 0.007762           # the tasks' grasp_lever
CLOSED_RAD = 0.1             # grasp_closed_below's default
PULL_SPEED_M_S = 0.02
TIMESTEP_S = 0.002           # the tasks'


def grasped_segment(pinch_n: float, slip_force_n: float | None = 1e3, friction: float | None = None, **keys):
    """The experiment's model, its jaw commanded to close at `pinch_n` (it takes hold within
    the first steps): (model, data, intestine). `slip_force_n` None and `friction` None leave the
    plugin's defaults; `keys`: further intestine keys."""
    command = CLOSED_RAD - pinch_n * LEVER_M / JAW_KP
    config = dict(length=LENGTH_M, radius=RADIUS_M, control_points=16, shape="line", direction=[1, 0, 0],
                  clamped="start", self_collision=0, damping=5, grasp_sites="jaws", grasp_joints="jaw",
                  grasp_lever=LEVER_M, grasp_slip_force=slip_force_n, grasp_friction=friction, **keys)
    worldbody = (f'<body name="carriage" pos="{LENGTH_M} 0 0">'
                 '<joint name="pull" type="slide" axis="1 0 0" damping="50"/>'
                 '<geom type="sphere" size="0.004" mass="0.1" contype="0" conaffinity="0"/>'
                 '<site name="jaws"/>'
                 f'<body name="jaw" pos="0 0 {LEVER_M}"><joint name="jaw" type="hinge" axis="0 1 0" damping="0.05"/>'
                 '<geom type="capsule" fromto="0 0 0 0.015 0 0" size="0.002" mass="0.01" contype="0" conaffinity="0"/>'
                 '</body></body>')
    actuators = ('<actuator><position name="pull" joint="pull" kp="4000"/>'
                 f'<position name="jaw" joint="jaw" kp="{JAW_KP}"/></actuator>')
    model, data, gut = compile_rod(config, TIMESTEP_S, gravity=(0, 0, 0), worldbody=worldbody, after=actuators)
    data.qpos[model.joint("jaw").qposadr[0]] = 0.4  # open
    data.ctrl[model.actuator("jaw").id] = command
    return model, data, gut


def slip_pull(pinch_n: float, slip_force_n: float | None = 1e3, friction: float | None = None,
              duration_s: float = 12.0) -> dict:
    """Pull the grasped segment at `pinch_n` until it slips: the largest pull the hold bore (N),
    the time it slipped (s) and the plugin's own pinch (N)."""
    model, data, gut = grasped_segment(pinch_n, slip_force_n, friction)
    carriage = model.body("carriage").id
    pull, held_from, slipped_at = 0.0, None, None
    for step in range(int(round(duration_s / TIMESTEP_S))):
        t = step * TIMESTEP_S
        if held_from is not None:
            data.ctrl[model.actuator("pull").id] = PULL_SPEED_M_S * max(0.0, t - held_from - 0.2)
        mujoco.mj_step(model, data)
        grasp = gut.grasps(data)[0]
        if grasp.slips:  # let go: at once if the jaws hold nothing at this pinch
            slipped_at = t
            break
        if grasp.holding:
            held_from = t if held_from is None else held_from
            pull = max(pull, float(np.linalg.norm(gut.body_wrench(data, carriage)[:3])))
    if held_from is None and slipped_at is None:
        raise RuntimeError(f"the jaws never closed on the bowel at {pinch_n} N")
    return {"pinch_n": pinch_n, "plugin_pinch_n": gut.pinches(data)[0][0], "slip_pull_n": pull if slipped_at else None,
            "held_pull_n": pull, "slipped_at_s": slipped_at}


def study(out: pathlib.Path | None = None, chart: pathlib.Path | None = None) -> dict:
    """The pull at slip across PINCHES_N, uncapped and with the default cap; the pinch that
    holds Heijnsdijk's 5 N (interpolated), against 3.0 +- 0.4 N."""
    import json

    from tqdm import tqdm
    uncapped = [slip_pull(p) for p in tqdm(PINCHES_N, desc="grasp slip, uncapped")]
    capped = [slip_pull(p, slip_force_n=None) for p in tqdm(PINCHES_N, desc="grasp slip, default cap")]
    pulls = np.array([r["slip_pull_n"] for r in uncapped])
    holds_5n = float(np.interp(HEIJNSDIJK_PULL_N, pulls, PINCHES_N))
    result = {"uncapped": uncapped, "default_cap": capped, "pinch_holding_5n": holds_5n,
              "measured": {"pull_n": HEIJNSDIJK_PULL_N, "pinch_n": HEIJNSDIJK_PINCH_N,
                           "pinch_sd_n": HEIJNSDIJK_PINCH_SD_N},
              "command": "python python/tools/validation/organ/grasp_slip.py"}
    if out is not None:
        out.write_text(json.dumps(result, indent=2) + "\n")
    if chart is not None:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(figsize=(6.4, 4.2))
        ax.plot(PINCHES_N, pulls, "o-", label="viscera, uncapped (grasp_slip_force 1000 N)")
        ax.plot(PINCHES_N, [r["slip_pull_n"] or r["held_pull_n"] for r in capped], "s--",
                label="viscera, tasks' default (capped at 5 N)")
        ax.errorbar([HEIJNSDIJK_PINCH_N], [HEIJNSDIJK_PULL_N], xerr=[HEIJNSDIJK_PINCH_SD_N], fmt="k*", ms=12,
                    capsize=4, label="pig small bowel (Heijnsdijk et al. 2004): 3.0 $\\pm$ 0.4 N holds 5 N")
        ax.set_xlabel("pinch (N)")
        ax.set_ylabel("pull at slip (N)")
        ax.set_title("Grasp-pull slip against the pinch")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(chart, dpi=110)
    return result


if __name__ == "__main__":
    docs = pathlib.Path(__file__).resolve().parents[4] / "docs" / "validation"
    result = study(docs / "organ.json", docs / "grasp_slip.png")
    print(f"pinch holding 5 N: {result['pinch_holding_5n']:.2f} N (pig small bowel: 3.0 +- 0.4 N)")
