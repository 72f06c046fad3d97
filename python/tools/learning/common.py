"""What the learning baselines share: seed ranges, evaluating a policy on unseen seeds with the
assessment's scores, library versions, and the learning-curve figure."""

from __future__ import annotations

import argparse
import importlib.metadata
import pathlib

import numpy as np

from viscera import assess


def seed_range(text: str) -> range:
    """'A:B' (argparse type): the seeds A to B - 1."""
    try:
        first, end = (int(part) for part in text.split(":"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: must be A:B, integers, A < B") from None
    if not 0 <= first < end:
        raise argparse.ArgumentTypeError(f"{text!r}: must be A:B with 0 <= A < B")
    return range(first, end)


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
    tracer.trace.success = bool(info["is_success"])
    scores = assess.score(tracer.trace)
    return {"seed": seed, "success": scores["success"], "return": total, "time_s": scores["time_s"],
            "path_length_m": sum(tool["path_length_m"] for tool in scores["tools"].values()),
            "peak_force_n": max(tool["peak_force_n"] for tool in scores["tools"].values()),
            "safety_cost": scores["safety_cost"]}


def summarise(episodes: list[dict]) -> dict:
    """Success rate and the medians of the scores over episodes (the successful ones' time)."""
    succeeded = [e for e in episodes if e["success"]]
    return {"episodes": len(episodes), "success_rate": len(succeeded) / len(episodes),
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
    """Success on the unseen seeds against environment steps and against CPU core-hours."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    curve = record["curve"]
    steps = [c["env_steps"] for c in curve]
    hours = [c["core_hours"] for c in curve]
    success = [100.0 * c["success_rate"] for c in curve]
    figure, (left, right) = plt.subplots(1, 2, figsize=(10, 3.6), sharey=True)
    left.plot(steps, success, marker="o")
    left.set_xlabel("environment steps")
    left.set_ylabel(f"success on {record['eval_seeds'][1] - record['eval_seeds'][0] + 1} unseen seeds (%)")
    right.plot(hours, success, marker="o", color="C1")
    right.set_xlabel("CPU core-hours (learner and environments)")
    for axes in (left, right):
        axes.set_ylim(-5, 105)
        axes.grid(alpha=0.3)
    figure.suptitle(f"{record['algorithm']} on {record['task']}")
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)
