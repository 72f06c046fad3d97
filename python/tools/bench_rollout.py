"""Threaded rollouts of the cavity scene: throughput against threads, with the serial loop as peer.

    python python/tools/bench_rollout.py [--batch 8] [--steps 250] [--runs 5] [--threads 1 2]

A batch of abdomen scenes (the task's scene, tools moving on smooth random
controls, each from a slightly bent intestine) is stepped three ways in the
same process, on the same initial states and controls:
  - python loop: mj_step on one MjData per batch entry, from Python (the peer);
  - rollout, k threads: viscera.scale.batch.BatchStepper (mujoco.rollout with k MjData
    sharing one MjModel; the GIL is released; the plugin keeps no globals, so threads scale).
The results of every threaded run are checked bit-identical to the serial
rollout's. Reported, medians over runs: physics steps per second, the speed-up
over one thread and the efficiency (speed-up / threads). The machine's core
count bounds the speed-up: on 2 cores, 2 threads at best double throughput.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import time

import viscera  # first: headless GL backend

import mujoco  # noqa: E402
import numpy as np  # noqa: E402
from tqdm import tqdm  # noqa: E402

from viscera import cli  # noqa: E402
from viscera.scale.batch import BatchStepper  # noqa: E402
from viscera.tasks import scene  # noqa: E402

FULLPHYSICS = mujoco.mjtState.mjSTATE_FULLPHYSICS


def batch_inputs(model: mujoco.MjModel, batch: int, steps: int, seed: int = 0):
    """Initial FULLPHYSICS states (a smooth random bend of the resting intestine) and smooth controls."""
    rng = np.random.default_rng(seed)
    gut = viscera.intestine(model)
    data = mujoco.MjData(model)
    initial = np.empty((batch, mujoco.mj_stateSize(model, FULLPHYSICS)))
    for b in range(batch):
        mujoco.mj_resetData(model, data)
        q = gut.positions(data)
        q += rng.normal(0.0, 0.002, 3) * np.sin(np.linspace(0.0, np.pi, len(q)) * rng.integers(1, 4))[:, None]
        mujoco.mj_getState(model, data, initial[b], FULLPHYSICS)
    if model.nu == 0:
        return initial, np.zeros((batch, steps, 0))
    low, high = model.actuator_ctrlrange.T
    knots = rng.uniform(low, high, (batch, 5, model.nu))
    t = np.linspace(0.0, 4.0, steps)
    controls = np.stack([np.stack([np.interp(t, np.arange(5), knots[b, :, u]) for u in range(model.nu)], axis=1)
                         for b in range(batch)])
    return initial, controls


def python_loop(model, initial, controls) -> np.ndarray:
    batch, steps = controls.shape[:2]
    final = np.empty_like(initial)
    for b in range(batch):
        data = mujoco.MjData(model)
        mujoco.mj_setState(model, data, initial[b], FULLPHYSICS)
        for t in range(steps):
            data.ctrl[:] = controls[b, t]
            mujoco.mj_step(model, data)
        mujoco.mj_getState(model, data, final[b], FULLPHYSICS)
    return final


def measure(batch: int = 8, steps: int = 250, runs: int = 5, thread_counts=(1, 2), progress: bool = True) -> dict:
    model = mujoco.MjModel.from_xml_path(str(scene.scene_file(scene.ABDOMEN)))
    initial, controls = batch_inputs(model, batch, steps)
    total_steps = batch * steps
    timings = {"python loop": []} | {f"rollout, {k} thread{'s' if k > 1 else ''}": [] for k in thread_counts}
    reference = None
    identical = True
    with tqdm(total=runs * len(timings), desc="rollout benchmark", disable=not progress) as bar:
        for _ in range(runs):
            start = time.perf_counter()
            python_loop(model, initial, controls)
            timings["python loop"].append(time.perf_counter() - start)
            bar.update()
            for k in thread_counts:
                with BatchStepper(model, threads=k) as stepper:
                    start = time.perf_counter()
                    states = stepper.step(initial, controls, chunk_size=1).state
                    timings[f"rollout, {k} thread{'s' if k > 1 else ''}"].append(time.perf_counter() - start)
                if reference is None:
                    reference = states
                identical &= bool(np.array_equal(states, reference))
                bar.update()
    one = statistics.median(timings[f"rollout, {thread_counts[0]} thread"]) if thread_counts[0] == 1 else None
    rows = {}
    for name, seconds in timings.items():
        median = statistics.median(seconds)
        threads = int(name.split(", ")[1].split()[0]) if name.startswith("rollout") else 1
        speedup = one / median if one else float("nan")
        rows[name] = {"seconds": median, "steps_per_s": total_steps / median, "speedup": speedup,
                      "efficiency": speedup / threads}
    return {"batch": batch, "steps": steps, "runs": runs, "cores": os.cpu_count(), "identical": identical,
            "simulated_s_per_entry": steps * model.opt.timestep, "rows": rows}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python python/tools/bench_rollout.py", description=__doc__.split("\n")[0])
    parser.add_argument("--batch", type=cli.positive_int, default=8, help="scenes per rollout (default 8)")
    parser.add_argument("--steps", type=cli.positive_int, default=250,
                        help="physics steps per scene (default 250: 0.5 s)")
    parser.add_argument("--runs", type=cli.positive_int, default=5, help="repeats, medians reported (default 5)")
    parser.add_argument("--threads", type=cli.positive_int, nargs="+", default=[1, 2],
                        help="thread counts (default 1 2)")
    parser.add_argument("--json", type=cli.output_file(".json"), help="also write the figures to this JSON file")
    parser.add_argument("--quiet", action="store_true", help="no progress bars")
    args = parser.parse_args(argv)
    threads = sorted(set(args.threads) | {1})
    result = measure(args.batch, args.steps, args.runs, tuple(threads), progress=not args.quiet)
    print(f"{args.batch} abdomens x {args.steps} steps, {result['cores']} cores, medians of {args.runs}; "
          f"threaded results bit-identical to serial: {result['identical']}")
    print(f"{'':20s} {'steps/s':>9s} {'speed-up':>9s} {'efficiency':>10s}")
    for name, row in result["rows"].items():
        print(f"{name:20s} {row['steps_per_s']:9.0f} {row['speedup']:9.2f} {row['efficiency']:10.2f}")
    if args.json:
        with open(args.json, "w") as out:
            json.dump(result, out, indent=1)
    return 0 if result["identical"] else 1


if __name__ == "__main__":
    raise SystemExit(main())
