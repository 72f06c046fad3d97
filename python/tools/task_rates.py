"""Success rates of the task suite: each task's scripted policy, uniform random actions and doing
nothing, over seeds, with the wall time and the intestine's divergence recoveries per episode;
written to docs/tasks/rates.json.

    python python/tools/task_rates.py [--seeds 50] [--first-seed 1000] [--tasks clear_area ...]
        [--policies scripted random nothing] [--max-steps N] [--scene abdomen|anatomical]
        [--time-limit-factor F] [--handover] [--noisy] [--merge docs/tasks/rates.json] [--out docs/tasks/rates.json]

The committed docs/tasks/rates.json holds the scripted oracles over 100 seeds, each also handed
to a fresh oracle at a quarter, half and three quarters of its episode (--handover), and random
actions and doing nothing over 20 (random 90 s episodes are slow), from two runs:

    python python/tools/task_rates.py --seeds 100 --policies scripted --handover --merge docs/tasks/rates.json \
        --out docs/tasks/rates.json
    python python/tools/task_rates.py --seeds 20 --policies random nothing --merge docs/tasks/rates.json \
        --out docs/tasks/rates.json

the scripted oracles on the anatomical abdomen into docs/tasks/rates_anatomical.json:

    python python/tools/task_rates.py --scene anatomical --seeds 100 --policies scripted \
        --out docs/tasks/rates_anatomical.json

and the two clearing tasks there with twice their time limits into docs/tasks/rates_anatomical_long.json:

    python python/tools/task_rates.py --scene anatomical --tasks clear_area retract_reach --policies scripted \
        --time-limit-factor 2 --out docs/tasks/rates_anatomical_long.json

and the stability check of random actions (a learning agent's first hours: 50 unseen seeds per
task, 300 control steps each, every recovery counted) into docs/tasks/random_stability.json:

    python python/tools/task_rates.py --policies random --first-seed 3000 --max-steps 300 \
        --out docs/tasks/random_stability.json

and the oracles under action noise throughout (--noisy: 2 % of each actuator's range every control
step), reading back the command noise made of theirs, as a policy does, or the command they meant
to send, into docs/tasks/rates_noisy.json:

    python python/tools/task_rates.py --seeds 100 --tasks grasp_lift --policies scripted --noisy \
        --out docs/tasks/rates_noisy.json
    python python/tools/task_rates.py --seeds 20 --tasks clear_area retract_reach run_the_bowel \
        --policies scripted --noisy --merge docs/tasks/rates_noisy.json --out docs/tasks/rates_noisy.json

The seeds start at 1000 by default: the policies were tuned on seeds below 200, and the oracles
also on the box abdomen's seeds 1000 to 1049, so seeds 1050 on are seeds they never saw (each
rate's `succeeded_seeds` gives both halves). Random actions are drawn uniformly in the action spec's bounds at every
control step (seeded by the episode's seed); doing nothing holds every tool where the episode
starts it (in the laparoscope's view).
With --time-limit-factor F each episode lasts F times its task's time limit (the oracles do not
read the clock): how much of a shortfall is the time, not the gesture.
Episodes run in worker processes, one per core.
"""

from __future__ import annotations

import argparse
import concurrent.futures
import json
import os
import pathlib
import time

import numpy as np
from tqdm import tqdm

import viscera
import viscera.tasks
from viscera import cli

POLICIES = ("scripted", "random", "nothing")
HANDOVER_FRACTIONS = (0.25, 0.5, 0.75)  # of each seed's scripted episode from the start
HANDOVER_NOISE = 0.02  # of each actuator's range, per control step, before a hand-over
# --noisy: what the oracle reads back as its last command, the one executed (noise and all, as the
# observation's tool_command gives it) or the one it meant to send
NOISY_READINGS = ("executed", "intended")
OUT = pathlib.Path("docs") / "tasks" / "rates.json"


def episode(task: str, seed: int, policy: str, max_steps: int | None = None, scene: str = "abdomen",
            time_limit_factor: float = 1.0, handover_s: float | None = None,
            handover_noise: float = HANDOVER_NOISE, noisy: str | None = None) -> dict:
    """One episode of `task` on `scene` from `seed` under `policy` (whole, or its first `max_steps`
    control steps), `time_limit_factor` times the task's time limit: success, simulated and wall
    seconds, the intestines' recoveries and divergences.

    With `handover_s`, the scripted oracle plays the first `handover_s` seconds with Gaussian
    noise of `handover_noise` times each actuator's range added to every action (drawn from the
    seed), then a fresh oracle, built anew, plays the rest from the state it is handed.

    With `noisy` ("executed" or "intended"), the scripted oracle plays the whole episode with that
    noise on every action; it reads its last command from the observation (`tool_command`, the
    command executed, noise and all), or, with "intended", the command it meant to send."""
    options = {} if time_limit_factor == 1.0 else {
        "time_limit": viscera.tasks.base.SUITE[task].TIME_LIMIT_S * time_limit_factor}
    env = viscera.tasks.load(task, seed=seed, scene=scene, **options)
    spec = env.action_spec()
    rng = np.random.RandomState(seed)
    act = viscera.tasks.scripted_policy(env) if policy == "scripted" else None
    noise_rng = np.random.default_rng([seed, 0xA0])
    spread = handover_noise * (spec.maximum - spec.minimum)
    start = time.perf_counter()
    step = env.reset()
    hold = env.physics.data.ctrl.copy()  # where the episode starts the tools: doing nothing holds them
    steps = 0
    handed = handover_s is None and noisy is None
    intended = None
    while not step.last() and (max_steps is None or steps < max_steps):
        steps += 1
        if not handed and handover_s is not None and env.physics.data.time >= handover_s - 1e-9:
            act, handed = viscera.tasks.scripted_policy(env), True  # fresh: it knows only what it is handed
        if policy == "scripted":
            if noisy == "intended" and intended is not None:
                step = step._replace(observation=dict(step.observation, tool_command=intended))
            action = intended = act(step)
            if not handed:
                action = np.clip(action + spread * noise_rng.standard_normal(action.shape), spec.minimum, spec.maximum)
        elif policy == "random":
            action = rng.uniform(spec.minimum, spec.maximum)
        else:
            action = hold.copy()
        step = env.step(action)
    guts = viscera.intestines(env.physics.model.ptr)
    data = env.physics.data.ptr
    return {"task": task, "seed": seed, "policy": policy, "success": bool(env.task.success(env.physics)),
            "simulated_s": float(env.physics.data.time), "wall_s": time.perf_counter() - start,
            "control_steps": steps, "recoveries": sum(gut.recovery_count(data) for gut in guts),
            "divergences": sum(gut.divergence_count(data) for gut in guts)}


def wilson_interval(successes: int, trials: int, z: float = 1.959964) -> list[float]:
    """The Wilson score interval of a success rate (95 % by default): [low, high]."""
    if trials == 0:
        return [0.0, 1.0]
    p = successes / trials
    centre = (p + z * z / (2 * trials)) / (1 + z * z / trials)
    half = z * np.sqrt(p * (1 - p) / trials + z * z / (4 * trials * trials)) / (1 + z * z / trials)
    return [float(max(0.0, centre - half)), float(min(1.0, centre + half))]


def rates(tasks, seeds, policies=POLICIES, workers: int | None = None, quiet: bool = False,
          max_steps: int | None = None, scene: str = "abdomen", time_limit_factor: float = 1.0,
          handover: bool = False, noisy: bool = False) -> dict:
    """Per task and policy: the success rate over `seeds` with its 95 % interval, the seeds that
    succeeded, the median wall time per episode, the recoveries and divergences (each episode's,
    and their total). With `handover`, the scripted policies again, each seed's episode handed to
    a fresh script at HANDOVER_FRACTIONS of its length from the start (episode's handover_s). With
    `noisy`, the scripted policies again under HANDOVER_NOISE throughout, reading back the executed
    command and their intended one (episode's `noisy`)."""
    jobs = [(task, seed, policy, max_steps, scene, time_limit_factor) for task in tasks for policy in policies for seed in seeds]
    with concurrent.futures.ProcessPoolExecutor(workers or os.cpu_count()) as pool:
        rows = list(tqdm(pool.map(episode, *zip(*jobs)), total=len(jobs), desc="episodes", disable=quiet))
        handed = []
        if handover and "scripted" in policies:
            control = 0.02
            later = [(r["task"], r["seed"], "scripted", max_steps, scene, time_limit_factor,
                      round(fraction * r["simulated_s"] / control) * control, HANDOVER_NOISE, fraction)
                     for fraction in HANDOVER_FRACTIONS for r in rows if r["policy"] == "scripted"]
            results = tqdm(pool.map(episode, *zip(*[job[:-1] for job in later])), total=len(later),
                           desc="hand-overs", disable=quiet)
            handed = [dict(r, fraction=job[-1]) for job, r in zip(later, results)]
        shaken = []
        if noisy and "scripted" in policies:
            jobs = [(task, seed, "scripted", max_steps, scene, time_limit_factor, None, HANDOVER_NOISE, reading)
                    for reading in NOISY_READINGS for task in tasks for seed in seeds]
            results = tqdm(pool.map(episode, *zip(*jobs)), total=len(jobs), desc="noisy", disable=quiet)
            shaken = [dict(r, reading=job[-1]) for job, r in zip(jobs, results)]
    out: dict = {}
    for task in tasks:
        for policy in policies:
            mine = [r for r in rows if r["task"] == task and r["policy"] == policy]
            out.setdefault(task, {})[policy] = {
                "episodes": len(mine), "seeds": [min(r["seed"] for r in mine), max(r["seed"] for r in mine)],
                "success_rate": float(np.mean([r["success"] for r in mine])),
                "interval_95": wilson_interval(sum(r["success"] for r in mine), len(mine)),
                "succeeded_seeds": [r["seed"] for r in mine if r["success"]],
                "median_wall_s_per_episode": float(np.median([r["wall_s"] for r in mine])),
                "median_simulated_s": float(np.median([r["simulated_s"] for r in mine])),
                "min_control_steps": min(r["control_steps"] for r in mine),
                "recoveries": [r["recoveries"] for r in mine], "recoveries_total": sum(r["recoveries"] for r in mine),
                "divergences_total": sum(r["divergences"] for r in mine)}
            if policy == "scripted" and handed:
                table = out[task][policy]["handover"] = {
                    "noise_of_range": HANDOVER_NOISE, "at": "fractions of each seed's scripted episode from the start",
                    "fractions": {}}
                for fraction in HANDOVER_FRACTIONS:
                    theirs = [r for r in handed if r["task"] == task and r["fraction"] == fraction]
                    wins = sum(r["success"] for r in theirs)
                    rate = wins / len(theirs)
                    table["fractions"][str(fraction)] = {
                        "success_rate": rate, "interval_95": wilson_interval(wins, len(theirs)),
                        "of_start_rate": rate / out[task][policy]["success_rate"] if out[task][policy]["success_rate"] else None,
                        "succeeded_seeds": [r["seed"] for r in theirs if r["success"]]}
            if policy == "scripted" and shaken:
                table = out[task][policy]["noisy"] = {"noise_of_range": HANDOVER_NOISE, "readings": {}}
                for reading in NOISY_READINGS:
                    theirs = [r for r in shaken if r["task"] == task and r["reading"] == reading]
                    wins = sum(r["success"] for r in theirs)
                    table["readings"][reading] = {
                        "episodes": len(theirs), "success_rate": wins / len(theirs),
                        "interval_95": wilson_interval(wins, len(theirs)),
                        "succeeded_seeds": [r["seed"] for r in theirs if r["success"]]}
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python python/tools/task_rates.py", description=__doc__.split("\n")[0])
    parser.add_argument("--seeds", type=cli.positive_int, default=50, help="episodes per task and policy (default 50)")
    parser.add_argument("--first-seed", type=cli.natural_int, default=1000,
                        help="the first seed (default 1000: seeds the policies were not tuned on)")
    parser.add_argument("--tasks", nargs="+", choices=viscera.tasks.ALL, default=list(viscera.tasks.ALL),
                        help="tasks to measure (default all)")
    parser.add_argument("--policies", nargs="+", choices=POLICIES, default=list(POLICIES),
                        help="policies to measure (default all)")
    parser.add_argument("--max-steps", type=cli.positive_int,
                        help="stop each episode after this many control steps (default: whole episodes)")
    parser.add_argument("--merge", type=cli.input_file,
                        help="a rates JSON whose other policies and tasks are kept beside this run's")
    parser.add_argument("--out", type=cli.output_file(".json"), help=f"where to write the rates (e.g. {OUT})")
    parser.add_argument("--scene", choices=sorted(viscera.tasks.scene.SCENES), default="abdomen",
                        help="the cavity the tasks load (default abdomen)")
    parser.add_argument("--time-limit-factor", type=cli.positive_float, default=1.0,
                        help="each episode lasts this many times its task's time limit (default 1)")
    parser.add_argument("--handover", action="store_true",
                        help="also hand each scripted episode to a fresh script at a quarter, half and three "
                             "quarters of its length, after noisy actions (2 %% of each actuator's range)")
    parser.add_argument("--noisy", action="store_true",
                        help="also play each scripted episode under noisy actions throughout (2 %% of each "
                             "actuator's range), the oracle reading back the executed command, then its intended one")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    args = parser.parse_args(argv)
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    result = {"control_timestep_s": 0.02, "scene": args.scene,
              "seeds": {policy: [seeds.start, seeds.stop - 1] for policy in args.policies},
              "rates": rates(args.tasks, seeds, args.policies, quiet=args.quiet, max_steps=args.max_steps,
                             scene=args.scene, time_limit_factor=args.time_limit_factor, handover=args.handover,
                             noisy=args.noisy)}
    if args.time_limit_factor != 1.0:
        result["time_limit_factor"] = args.time_limit_factor
    if args.max_steps:
        result["max_control_steps"] = args.max_steps
    if args.merge:  # this run's policies over the merged file's
        merged = json.loads(pathlib.Path(args.merge).read_text())
        merged["seeds"].update(result["seeds"])
        for task, table in result["rates"].items():
            merged["rates"].setdefault(task, {}).update(table)
        result = merged
    for task, table in result["rates"].items():
        print(task + ": " + ", ".join(f"{policy} {row['success_rate']:.0%} ({row['median_wall_s_per_episode']:.1f} s "
                                      f"wall per episode, {row.get('recoveries_total', 0)} recoveries)"
                                      for policy, row in table.items()))
        for fraction, row in table.get("scripted", {}).get("handover", {}).get("fractions", {}).items():
            print(f"  handed to a fresh script at {float(fraction):.0%} of the episode: {row['success_rate']:.0%}")
        for reading, row in table.get("scripted", {}).get("noisy", {}).get("readings", {}).items():
            print(f"  under noise throughout, reading its {reading} command: {row['success_rate']:.0%}")
    if args.out:
        pathlib.Path(args.out).write_text(json.dumps(result, indent=2) + "\n")
        print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
