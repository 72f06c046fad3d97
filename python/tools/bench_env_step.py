"""What a learner pays for the task code: an environment's step and reset against the bare physics.

    python python/tools/bench_env_step.py [--tasks clear_area grasp_lift ...] [--steps 400] [--runs 10]
        [--seed 1000] [--json docs/bench/env_step.json]

Per task, the scripted policy plays `steps` control steps of the episode `seed` once, and every
control step's actuator targets (what the task's before_step writes into ctrl) are kept. Then, in
each run, alternated:
- env: the episode `seed` reset again (the task reseeded), then the same actions through
  `env.step` (the task's before_step, the physics, after_step's measurements, condition and
  reward, and the observation), timing the steps;
- bare: the same start state, then per step the kept ctrl and the control step's `mj_step` calls
  alone: the physics of the same control steps, nothing of the task.
- reset: `env.reset()` alone.
Both end in the same state, bit for bit (`same_final_state` in the JSON): they time the same
physics. The ratios are medians over runs of env / bare, and of a reset over one mean env step. The goals
(issue 41): a step at most 1.3x its physics, a reset at most the time of 10 steps.
"""

from __future__ import annotations

import argparse
import json
import os
import pathlib
import platform
import statistics
import sys
import time

import mujoco
import numpy as np
from tqdm import tqdm

import viscera.tasks

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from bench_scale import cpu_model  # noqa: E402

OUT = pathlib.Path("docs") / "bench" / "env_step.json"
FULL = mujoco.mjtState.mjSTATE_FULLPHYSICS


def play(task: str, seed: int, steps: int):
    """The environment, its start state, the scripted actions and each step's ctrl."""
    env = viscera.tasks.load(task, seed=seed)
    policy = viscera.tasks.scripted_policy(env)
    step = env.reset()
    model, data = env.physics.model.ptr, env.physics.data.ptr
    start = np.empty(mujoco.mj_stateSize(model, FULL))
    mujoco.mj_getState(model, data, start, FULL)
    actions, controls = [], []
    for _ in range(steps):
        actions.append(policy(step))
        step = env.step(actions[-1])
        controls.append(data.ctrl.copy())
        if step.last():
            break
    return env, start, actions, controls


def final_state(env) -> bytes:
    model, data = env.physics.model.ptr, env.physics.data.ptr
    state = np.empty(mujoco.mj_stateSize(model, FULL))
    mujoco.mj_getState(model, data, state, FULL)
    return state.tobytes()


def time_env(env, seed: int, actions) -> tuple[float, bytes]:
    """The episode `seed` again (reseeded: a reset draws the next episode otherwise), its actions
    through env.step; the time and the final state."""
    viscera.tasks.reseed(env, seed)
    env.reset()
    begin = time.perf_counter()
    for action in actions:
        env.step(action)
    return time.perf_counter() - begin, final_state(env)


def time_bare(env, seed: int, start, controls) -> tuple[float, bytes]:
    """The episode `seed`'s model (reseeded and reset: the model holds the last reset's episode)
    from its start state, the kept ctrl and mj_step alone; the time and the final state."""
    viscera.tasks.reseed(env, seed)
    env.reset()
    model, data = env.physics.model.ptr, env.physics.data.ptr
    substeps = int(round(env.control_timestep() / model.opt.timestep))
    mujoco.mj_setState(model, data, start, FULL)
    mujoco.mj_forward(model, data)
    begin = time.perf_counter()
    for ctrl in controls:
        data.ctrl[:] = ctrl
        for _ in range(substeps):
            mujoco.mj_step(model, data)
    return time.perf_counter() - begin, final_state(env)


def time_reset(env) -> float:
    begin = time.perf_counter()
    env.reset()
    return time.perf_counter() - begin


def measure(task: str, seed: int, steps: int, runs: int, bar) -> dict:
    env, start, actions, controls = play(task, seed, steps)
    ratios, resets, env_ms, bare_ms = [], [], [], []
    same = True
    for run in range(runs):
        if run % 2:  # which goes first alternates: neither always finds the caches the other warmed
            (bare_s, bare_end), (env_s, env_end) = time_bare(env, seed, start, controls), time_env(env, seed, actions)
        else:
            (env_s, env_end), (bare_s, bare_end) = time_env(env, seed, actions), time_bare(env, seed, start, controls)
        same = same and env_end == bare_end  # the same physics, or the ratio compares two episodes
        reset_s = time_reset(env)
        ratios.append(env_s / bare_s)
        resets.append(reset_s / (env_s / len(actions)))
        env_ms.append(1e3 * env_s / len(actions))
        bare_ms.append(1e3 * bare_s / len(actions))
        bar.update()
    return {"steps": len(actions), "same_final_state": same, "step_over_physics": statistics.median(ratios),
            "step_over_physics_runs": [round(r, 3) for r in ratios],
            "reset_over_step": statistics.median(resets), "reset_over_step_runs": [round(r, 1) for r in resets],
            "env_step_ms": statistics.median(env_ms), "physics_step_ms": statistics.median(bare_ms),
            "reset_ms": statistics.median(resets) * statistics.median(env_ms)}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python python/tools/bench_env_step.py", description=__doc__.split("\n")[0])
    parser.add_argument("--tasks", nargs="+", choices=viscera.tasks.ALL, default=list(viscera.tasks.ALL))
    parser.add_argument("--steps", type=int, default=400, help="control steps of the scripted episode timed")
    parser.add_argument("--runs", type=int, default=10, help="alternated runs; medians are reported")
    parser.add_argument("--seed", type=int, default=1000, help="the episode's seed")
    parser.add_argument("--json", default=str(OUT), help="where to write the results")
    args = parser.parse_args(argv)
    results = {}
    with tqdm(total=len(args.tasks) * args.runs, desc="env step and reset", unit="run") as bar:
        for task in args.tasks:
            results[task] = measure(task, args.seed, args.steps, args.runs, bar)
    record = {"command": "python python/tools/bench_env_step.py", "seed": args.seed, "runs": args.runs,
              "machine": {"cpu": cpu_model(), "cpus": os.cpu_count(), "python": platform.python_version()},
              "goals": {"step_over_physics": 1.3, "reset_over_step": 10.0}, "tasks": results}
    pathlib.Path(args.json).parent.mkdir(parents=True, exist_ok=True)
    pathlib.Path(args.json).write_text(json.dumps(record, indent=1) + "\n")
    for task, r in results.items():
        print(f"{task:14s} step {r['step_over_physics']:.2f}x its physics ({r['env_step_ms']:.2f} ms against "
              f"{r['physics_step_ms']:.2f} ms), reset {r['reset_over_step']:.0f} steps ({r['reset_ms']:.0f} ms)")
    print(f"medians of {args.runs} alternated runs on {record['machine']['cpu']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
