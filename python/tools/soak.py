"""Soak: the clear_area task under random tool motion for a long simulated time.

    python python/tools/soak.py --minutes 30          # the figures in docs/robustness.md and docs/soak/

One episode with no reset (the time limit is the soak's length). Every few
seconds each tool takes a new random target: a joint configuration whose tool
tip lies inside the cavity (the walls' inner faces, less a 1 cm margin; the
tools have no MuJoCo contacts with the walls, so a target outside would push
the bowel through a wall no real instrument crosses). The commanded controls
follow the targets through a first-order filter (time constant 0.3 s); the
grasper's jaws open and close at random. Each control step checks that the
state is finite; each simulated second records the resident memory, the
plugin's divergence and recovery counters, and how far the intestine reaches
out of the cavity:

- penetration (m): how deep the tube's surface enters a wall (0 when every
  axis point is at least one radius inside every inner face);
- escaped: whether an axis point ever lay beyond a wall's outer face, i.e. left.

Memory growth is the slope of a straight line fitted to the resident memory
after the first simulated minute (MB per simulated minute).
"""

from __future__ import annotations

import argparse
import json
import os
import pathlib
import time

import mujoco
import numpy as np
import tqdm

from viscera import cli, tasks

WALLS = ("posterior_wall", "left_flank", "right_flank", "pelvis_floor", "cranial_wall", "anterior_wall")
TIP_MARGIN = 0.01         # m: targets keep the tool tips this far inside the inner faces
FILTER_TIME = 0.3         # s: time constant from target to command
TARGET_HOLD = (1.0, 4.0)  # s: each target lasts a uniform time in this range
OUT_DIR = pathlib.Path(__file__).resolve().parents[2] / "docs" / "soak"


def cavity_box(model: mujoco.MjModel, data: mujoco.MjData) -> tuple[np.ndarray, np.ndarray, float]:
    """Inner faces of the six wall boxes (low corner, high corner, m) and the walls' thinnest thickness (m)."""
    low, high, thickness = np.full(3, -np.inf), np.full(3, np.inf), np.inf
    centre = np.mean([data.geom(w).xpos for w in WALLS], axis=0)
    for name in WALLS:
        geom = model.geom(name)
        axis = int(np.argmin(geom.size))  # walls are thin along one world axis
        position = data.geom(name).xpos[axis]
        thickness = min(thickness, 2.0 * geom.size[axis])
        if position < centre[axis]:
            low[axis] = max(low[axis], position + geom.size[axis])
        else:
            high[axis] = min(high[axis], position - geom.size[axis])
    return low, high, thickness


def _outside(points: np.ndarray, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """Distance (m) of each point beyond the box, along the worst axis (0 inside)."""
    return np.maximum(np.maximum(low - points, points - high), 0.0).max(axis=1)


class RandomSurgeon:
    """Random targets whose tool tips lie inside the cavity, followed through a low-pass filter."""

    def __init__(self, physics, rng: np.random.Generator, low: np.ndarray, high: np.ndarray):
        self.model = physics.model.ptr
        self.scratch = mujoco.MjData(self.model)
        self.rng = rng
        self.low, self.high = low + TIP_MARGIN, high - TIP_MARGIN
        self.ctrl_low, self.ctrl_high = self.model.actuator_ctrlrange.T.copy()
        self.joint_qpos = self.model.jnt_qposadr[self.model.actuator_trnid[:, 0]]
        self.command = physics.data.ctrl.copy()
        self.target = self.command.copy()
        self.next_change = np.zeros(self.model.nu)

    def _tip_points(self, data: mujoco.MjData) -> np.ndarray:
        points = [data.site("grasper_tip").xpos, data.geom("grasper_jaw").xpos]
        paddle = data.geom("retractor_paddle")
        half = self.model.geom("retractor_paddle").size
        along = paddle.xmat.reshape(3, 3)[:, 2] * half[1]
        points += [paddle.xpos + along, paddle.xpos - along]
        return np.array(points)

    def _inside(self, ctrl: np.ndarray) -> bool:
        self.scratch.qpos[:] = self.model.qpos0
        self.scratch.qpos[self.joint_qpos] = ctrl  # position actuators: the target is the joint position
        mujoco.mj_kinematics(self.model, self.scratch)
        return bool(np.all(_outside(self._tip_points(self.scratch), self.low, self.high) == 0.0))

    def action(self, time_s: float, control_timestep: float) -> np.ndarray:
        due = self.next_change <= time_s
        if due.any():
            for _ in range(1000):  # rejection sampling: most draws put a tip through a wall
                candidate = self.target.copy()
                candidate[due] = self.rng.uniform(self.ctrl_low[due], self.ctrl_high[due])
                if self._inside(candidate):
                    self.target = candidate
                    break
            self.next_change[due] = time_s + self.rng.uniform(*TARGET_HOLD, size=int(due.sum()))
        self.command += (self.target - self.command) * (1.0 - np.exp(-control_timestep / FILTER_TIME))
        return self.command.copy()


def _resident_mb() -> float:
    with open("/proc/self/statm") as statm:
        return int(statm.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 1e6


def soak(minutes: float = 30.0, seed: int = 0, progress: bool = True) -> dict:
    seconds = int(round(minutes * 60.0))
    env = tasks.load("clear_area", seed=seed, time_limit=seconds + 1.0, end_on_success=False)
    env.reset()
    physics = env.physics
    model, data = physics.model.ptr, physics.data.ptr
    gut = physics.intestine()
    low, high, thickness = cavity_box(model, data)
    surgeon = RandomSurgeon(physics, np.random.default_rng(seed), low, high)
    control_timestep = env.control_timestep()
    per_second = int(round(1.0 / control_timestep))
    record = {key: [] for key in ("time_s", "resident_mb", "penetration_m", "outside_axis_m", "divergences",
                                  "recoveries", "wall_s", "holding")}
    first_non_finite = None
    wall_start = time.perf_counter()
    for second in tqdm.trange(seconds, desc="soak (simulated s)", disable=not progress, mininterval=2.0):
        tick = time.perf_counter()
        for _ in range(per_second):
            env.step(surgeon.action(data.time, control_timestep))
            finite = (np.isfinite(data.qpos).all() and np.isfinite(data.qvel).all()
                      and np.isfinite(data.plugin_state).all())
            if not finite and first_non_finite is None:
                first_non_finite = float(data.time)
        axis = gut.axis_points(data, 4 * gut.sphere_count)
        record["time_s"].append(float(data.time))
        record["resident_mb"].append(_resident_mb())
        record["penetration_m"].append(float(_outside(axis, low + gut.radius, high - gut.radius).max()))
        record["outside_axis_m"].append(float(_outside(axis, low, high).max()))
        record["divergences"].append(gut.divergence_count(data))
        record["recoveries"].append(gut.recovery_count(data))
        record["wall_s"].append(time.perf_counter() - tick)
        record["holding"].append(float(physics.holding().max()))
    wall = time.perf_counter() - wall_start
    times = np.array(record["time_s"])
    memory = np.array(record["resident_mb"])
    settled = times >= min(60.0, times[-1] / 2.0)
    slope = float(np.polyfit(times[settled] / 60.0, memory[settled], 1)[0]) if settled.sum() > 2 else 0.0
    return {
        "simulated_s": float(times[-1]),
        "wall_s": wall,
        "wall_per_simulated_s": wall / float(times[-1]),
        "first_non_finite_s": first_non_finite,
        "max_penetration_m": max(record["penetration_m"]),
        "max_axis_outside_inner_faces_m": max(record["outside_axis_m"]),
        "wall_thickness_m": thickness,
        "escaped": bool(max(record["outside_axis_m"]) > thickness),
        "divergences": record["divergences"][-1],
        "recoveries": record["recoveries"][-1],
        "resident_mb_first": float(memory[0]),
        "resident_mb_last": float(memory[-1]),
        "resident_mb_max": float(memory.max()),
        "memory_growth_mb_per_simulated_min": slope,
        "time_holding_fraction": float(np.mean(record["holding"])),
        "series": record,
    }


def plot(result: dict, path: pathlib.Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    series = result["series"]
    minutes = np.array(series["time_s"]) / 60.0
    figure, axes = plt.subplots(3, 1, figsize=(7, 7), sharex=True)
    axes[0].plot(minutes, series["resident_mb"])
    axes[0].set_ylabel("resident memory (MB)")
    axes[0].set_title(f"clear_area, random tool motion: growth "
                      f"{result['memory_growth_mb_per_simulated_min']:+.3f} MB per simulated min")
    axes[1].plot(minutes, 1e3 * np.array(series["penetration_m"]), label="tube surface into a wall")
    axes[1].axhline(1e3 * (result["wall_thickness_m"]), color="k", ls="--", lw=0.8, label="wall thickness")
    axes[1].set_ylabel("depth (mm)")
    axes[1].legend(loc="upper right", fontsize=8)
    axes[2].plot(minutes, series["wall_s"])
    axes[2].set_ylabel("wall s per simulated s")
    axes[2].set_xlabel("simulated time (min)")
    figure.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path, dpi=110)
    plt.close(figure)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python python/tools/soak.py", description=__doc__.split("\n")[0])
    parser.add_argument("--minutes", type=cli.positive_float_up_to(cli.MAX_DURATION_S / 60, "min"), default=30.0, help="simulated minutes (default 30)")
    parser.add_argument("--seed", type=cli.natural_int, default=0, help="seed of the random tool motion (default 0)")
    parser.add_argument("--out", type=pathlib.Path, default=OUT_DIR, help="where results.json and soak.png go")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    args = parser.parse_args(argv)
    result = soak(args.minutes, args.seed, progress=not args.quiet)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "results.json").write_text(json.dumps(result, indent=1))
    plot(result, args.out / "soak.png")
    summary = {k: v for k, v in result.items() if k != "series"}
    print(json.dumps(summary, indent=1))
    healthy = (result["first_non_finite_s"] is None and not result["escaped"]
               and result["memory_growth_mb_per_simulated_min"] < 1.0)
    return 0 if healthy else 1


if __name__ == "__main__":
    raise SystemExit(main())
