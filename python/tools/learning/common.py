"""What the learning baselines share: seed ranges, evaluating a policy on unseen seeds with the
assessment's scores, wall and CPU clocks, library versions, and the learning-curve figure."""

from __future__ import annotations

import importlib.metadata
import pathlib
import resource
import sys
import time

import numpy as np

from viscera import assess
from viscera.cli import fraction, seed_range  # noqa: F401  (argparse types of the tools' options)

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1]))  # python/tools
from task_rates import wilson_interval  # noqa: E402  (the 95 % interval the oracles' rates give too)


def episode(env, act, seed: int) -> dict:
    """One episode of a gymnasium TaskEnv from `seed`, `act(observation) -> action` choosing each
    action: success, return and the assessment's scores (viscera.assess)."""
    observation, info = env.reset(seed=seed)
    if hasattr(act, "reset"):
        act.reset()  # a policy with memory (a step count) starts over
    tracer = assess.Tracer(env.dm_env)
    tracer.sample(env.dm_env)
    total, done = 0.0, False
    while not done:
        observation, reward, terminated, truncated, info = env.step(act(observation))
        tracer.sample(env.dm_env)
        total += reward
        done = terminated or truncated
    return _scored(tracer, seed, bool(info["is_success"]), total)


def policy_episode(env, policy, seed: int) -> dict:
    """One episode of a gymnasium TaskEnv's dm_env from `seed`, `policy(time_step) -> dm_env action`
    (a scripted policy, or a viscera.policy_file.LearnedPolicy: it starts over on the first time
    step) acting as `python -m viscera play` runs it: episode()'s scores."""
    env.reset(seed=seed)
    time_step = env.time_step
    tracer = assess.Tracer(env.dm_env)
    tracer.sample(env.dm_env)
    total = 0.0
    while not time_step.last():
        time_step = env.dm_env.step(policy(time_step))
        tracer.sample(env.dm_env)
        total += float(time_step.reward)
    env.end_episode()
    return _scored(tracer, seed, bool(env.dm_env.task.success(env.dm_env.physics)), total)


def _scored(tracer, seed: int, success: bool, total: float) -> dict:
    tracer.trace.success = success
    scores = assess.score(tracer.trace)
    return {"seed": seed, "success": scores["success"], "return": total, "time_s": scores["time_s"],
            "path_length_m": sum(tool["path_length_m"] for tool in scores["tools"].values()),
            "peak_force_n": max(tool["peak_force_n"] for tool in scores["tools"].values()),
            "safety_cost": scores["safety_cost"]}


class Clock:
    """Wall and CPU seconds between laps; the CPU of this process and of its finished child
    processes (worker pools), all threads included."""

    def __init__(self):
        self._last = self._now()

    @staticmethod
    def _now() -> tuple[float, float]:
        own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
        return time.perf_counter(), own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime

    def lap(self) -> dict:
        """{"wall_s", "cpu_s"} since the last lap (or the clock's start)."""
        now = self._now()
        lap = {"wall_s": now[0] - self._last[0], "cpu_s": now[1] - self._last[1]}
        self._last = now
        return lap


def summarise(episodes: list[dict]) -> dict:
    """Success rate with its 95 % interval, and the medians of the scores over episodes (the
    successful ones' time)."""
    succeeded = [e for e in episodes if e["success"]]
    return {"episodes": len(episodes), "success_rate": len(succeeded) / len(episodes),
            "success_interval_95": wilson_interval(len(succeeded), len(episodes)),
            "succeeded_seeds": [e["seed"] for e in succeeded],
            "mean_return": float(np.mean([e["return"] for e in episodes])),
            "median_time_to_success_s": float(np.median([e["time_s"] for e in succeeded])) if succeeded else None,
            "median_path_length_m": float(np.median([e["path_length_m"] for e in episodes])),
            "median_peak_force_n": float(np.median([e["peak_force_n"] for e in episodes])),
            "median_safety_cost": float(np.median([e["safety_cost"] for e in episodes]))}


def evaluate_policy(env, act, seeds) -> dict:
    """summarise() of one episode per seed."""
    return summarise([episode(env, act, int(seed)) for seed in seeds])


def state_names(env) -> list[str]:
    """The names of a TaskEnv's flat state entries, "key[i]"."""
    from viscera.datasets.episodes import state_names as names

    return names(env.observation_layout)


def versions(*modules: str) -> dict:
    names = ("viscera", "mujoco") + modules
    found = {}
    for name in names:
        try:
            found[name] = importlib.metadata.version(name.replace("_", "-"))
        except importlib.metadata.PackageNotFoundError:
            found[name] = None
    return found


def curve_figure(record: dict, path: pathlib.Path) -> None:
    """Success and mean return on the unseen seeds against environment steps and against CPU
    core-hours, with the scripted policy's and random actions' returns on the same seeds."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    curve = record["curve"]
    count = record["eval_seeds"][1] - record["eval_seeds"][0] + 1
    figure, axes = plt.subplots(2, 2, figsize=(10, 6), sharex="col", sharey="row")
    for column, (key, label) in enumerate((("env_steps", "environment steps"),
                                           ("core_hours", "CPU core-hours (learner and environments)"))):
        x = [c[key] for c in curve]
        axes[0, column].plot(x, [100.0 * c["success_rate"] for c in curve], marker="o")
        axes[0, column].set_ylim(-5, 105)
        axes[1, column].plot(x, [c["mean_return"] for c in curve], marker="o", color="C1", label="PPO")
        for number, attempt in enumerate(record.get("attempts", [])):  # earlier runs, thin and dashed
            xs = [c[key] for c in attempt["curve"]]
            style = dict(marker=".", linestyle=":", linewidth=1, color=f"C{4 + number}")
            axes[0, column].plot(xs, [100.0 * c["success_rate"] for c in attempt["curve"]], **style)
            axes[1, column].plot(xs, [c["mean_return"] for c in attempt["curve"]],
                                 label=f"attempt {number + 1}: {attempt['start'].split('(')[0].split(',')[0].strip()}", **style)
        for name, reference in record.get("references_on_eval_seeds", {}).items():
            axes[1, column].axhline(reference["mean_return"], linestyle="--", color="C2" if name == "scripted" else "C3",
                                    label=f"{name} ({100 * reference['success_rate']:.0f} % success)")
        axes[1, column].set_xlabel(label)
        for row in axes[:, column]:
            row.grid(alpha=0.3)
    axes[0, 0].set_ylabel(f"success on {count} unseen seeds (%)")
    axes[1, 0].set_ylabel("mean episode return")
    axes[1, 1].legend(loc="center right", fontsize=7)
    figure.suptitle(f"{record['algorithm']} on {record['task']}")
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)


# -- what a network can read

# The smallest scale each observation entry is normalised by, whatever the demonstrations' spread
# (issue: an entry the demonstrator never moves, say a roll joint spreading 2e-4 rad, divided by
# that spread puts a 2 degree roll 150 spreads from anything seen). By the entry's unit:
MILLIMETRE, DEGREE, NEWTON, NEWTON_METRE, SHARE, GRAVITY = 1e-3, np.pi / 180.0, 0.1, 0.01, 0.05, 0.1
# per observation key: a floor, or "joints" (each actuator's own unit: m for a depth, rad otherwise)
# or "wrench" (6 per tool: force N, then torque N m) or "pose" (a position, m, then a unit direction,
# whose components move by about the angle turned, rad)
FLOORS = {"tool_joints": "joints", "tool_command": "joints", "tool_forces": "wrench", "grasper_holding": SHARE,
          "intestine_axis": MILLIMETRE, "gravity": GRAVITY, "band": MILLIMETRE, "held_abscissa": MILLIMETRE,
          "band_abscissa": MILLIMETRE, "target": MILLIMETRE, "target_coverage": SHARE, "grasper_tip": MILLIMETRE,
          "start_mark": MILLIMETRE, "intestine_length": MILLIMETRE, "advance": MILLIMETRE,
          "counted_abscissa": MILLIMETRE, "camera_pose": "pose"}
# normalised entries are clipped to this many scales from the demonstrations' mean
INPUT_CLIP = 5.0


def observation_floors(names: list[str], action_names: list[str]) -> np.ndarray:
    """Each flat state entry's floor (its unit's: 1 mm, 1 degree, 0.1 N, 0.01 N m, 0.05 of a share,
    0.1 m/s^2), from its name "key[i]" and the actuators' names; an unknown key is an error."""
    floors = np.empty(len(names))
    for j, name in enumerate(names):
        key, index = name.split("[")[0], int(name.split("[")[1].rstrip("]"))
        if key not in FLOORS:
            raise KeyError(f"observation entry {name!r}: no unit known for {key!r} (common.FLOORS)")
        kind = FLOORS[key]
        if kind == "joints":
            floors[j] = MILLIMETRE if action_names[index].endswith("_depth") else DEGREE
        elif kind == "wrench":
            floors[j] = NEWTON if index % 6 < 3 else NEWTON_METRE
        elif kind == "pose":
            floors[j] = MILLIMETRE if index < 3 else DEGREE
        else:
            floors[j] = kind
    return floors
