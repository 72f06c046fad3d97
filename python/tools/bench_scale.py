"""Throughput: the clearing task's env steps per second against workers, per backend; each task's.

    python python/tools/bench_scale.py [--runs 5] [--workers 1 2 4] [--envs-per-worker 2] [--steps 100]
                                  [--parts collect vector tasks]
                                  [--json docs/scale/results.json] [--png docs/scale/scaling.png]

Weak scaling, all in this process: each worker holds `envs-per-worker`
clear_area environments and steps them `steps` control steps (0.02 s each) under
the seeded random policy, so the work grows with the workers. Per backend of
viscera.scale.collect (threads, processes, Ray actors) and worker count, after
one warm-up collection on the same workers: env steps per second (medians of
`runs`), the speed-up over the serial backend on the same seeds in the same run
(the peer: a seed's episode sets its cost), and the efficiency (speed-up / workers). Worker counts past the cores
show where scaling stops: the speed-up cannot exceed the core count. Ray is
started with as many logical CPUs as the largest worker count, so that it too
may oversubscribe the cores.

Also measured: the gymnasium vector envs (viscera.scale.vector, one step of all
envs per call), the bytes of trajectory per env step, the start-up time of each
backend's workers, and the round trip of an empty Ray actor call, the physics' share of an env step (the
part threads run in parallel) and a worker's memory: the figures
the 1,000-core plan in docs/scaling.md starts from. Every collection is checked
bit-identical to the serial one.

Per task (`--parts tasks`, every task of viscera.tasks.ALL): one environment, serial, its reset
(the physics rebuilt for the episode, then 0.5 s of settling) and its env steps per second under
three policies: the task's scripted policy, uniform random actions and smooth random actions
(the collections' policy); medians over `runs` seeds.
"""

from __future__ import annotations

import argparse
import concurrent.futures
import json
import multiprocessing
import os
import platform
import statistics
import time

import mujoco
import numpy as np
from tqdm import tqdm

from viscera import cli, scale
from viscera.scale import vector
from viscera.scale.batch import available_cores
from bench_rollout import batch_inputs
from viscera.tasks import scene

TASK = "clear_area"


def measure_collect(worker_counts, envs_per_worker, steps, runs, backends, bar) -> dict:
    most = max(worker_counts)
    all_seeds = list(range(most * envs_per_worker))
    reference = scale.collect(TASK, all_seeds, steps, backend="serial")
    bytes_per_step = sum(t.nbytes for t in reference) / (len(reference) * steps)
    rows, peer, startup = [], {}, {}
    ray_init = {"num_cpus": most, "include_dashboard": False, "log_to_driver": False}
    for workers in worker_counts:
        seeds = all_seeds[:workers * envs_per_worker]
        # the peer: the same seeds on the serial backend (a seed's episode sets its cost: contacts, grasps)
        collectors = {"serial": scale.make_collector("serial", TASK)}
        for backend in backends:
            start = time.perf_counter()
            collectors[backend] = scale.make_collector(backend, TASK, workers,
                                                       **({"ray_init": ray_init} if backend == "ray" else {}))
            if workers == most:
                collectors[backend].collect(seeds[:workers], 1)  # one environment per worker loaded
                startup[backend] = time.perf_counter() - start
        for collector in collectors.values():
            collector.collect(seeds, steps)  # warm-up: environments loaded, caches filled
        seconds = {name: [] for name in collectors}
        identical = dict.fromkeys(collectors, True)
        names = list(collectors)
        for run in range(runs):  # round robin from a rotating start: drifts and order reach every backend alike
            for name in names[run % len(names):] + names[:run % len(names)]:
                collector = collectors[name]
                start = time.perf_counter()
                trajectories = collector.collect(seeds, steps)
                seconds[name].append(time.perf_counter() - start)
                identical[name] &= all(a.same_as(b) for a, b in zip(trajectories, reference))
                bar.update()
        for collector in collectors.values():
            collector.close()
        peer[workers] = len(seeds) * steps / statistics.median(seconds["serial"])
        for name in collectors:
            rate = len(seeds) * steps / statistics.median(seconds[name])
            used = 1 if name == "serial" else workers
            rows.append({"backend": name, "workers": used, "envs": len(seeds),
                         "seconds": statistics.median(seconds[name]), "steps_per_s": rate,
                         "speedup": rate / peer[workers], "efficiency": rate / peer[workers] / used,
                         "identical": identical[name]})
    return {"rows": rows, "serial_steps_per_s": peer, "bytes_per_step": bytes_per_step,
            "startup_s": startup, "observation_size": int(reference[0].observations.shape[1])}


def physics_fraction(steps: int = 200) -> float:
    """The share of an env step's wall time spent in the physics (MuJoCo, GIL released), one env."""
    import viscera.tasks
    env = viscera.tasks.load(TASK, seed=0)
    env.reset()
    inner, spent = env.physics.step, [0.0]

    def timed_physics_step(*args, **kwargs):
        start = time.perf_counter()
        inner(*args, **kwargs)
        spent[0] += time.perf_counter() - start

    env.physics.step = timed_physics_step  # dm_control's Environment.step calls physics.step(n_sub_steps)
    start = time.perf_counter()
    for action in smooth_actions(1, steps)[:, 0]:
        env.step(action)
    return spent[0] / (time.perf_counter() - start)


def _resident_mb() -> float:
    with open("/proc/self/statm") as statm:
        return int(statm.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 1e6


def _worker_memory() -> tuple[float, float]:
    """In a fresh process: resident MB of a worker holding one environment, and MB per further environment."""
    worker = scale.RolloutWorker(TASK)
    worker.run([0], 2)
    one = _resident_mb()
    worker.run(list(range(9)), 2)
    return one, (_resident_mb() - one) / 8


def worker_memory() -> dict:
    with concurrent.futures.ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn")) as pool:
        one, per_env = pool.submit(_worker_memory).result()
    return {"process_with_one_env_MB": one, "per_further_env_MB": per_env}


def cpu_model() -> str:
    try:
        with open("/proc/cpuinfo") as info:
            return next(line.split(":", 1)[1].strip() for line in info if line.startswith("model name"))
    except (OSError, StopIteration):
        return platform.processor() or "unknown"


def smooth_actions(num_envs: int, steps: int) -> np.ndarray:
    """(steps, num_envs, nu) smooth random tool controls within the action bounds, as the collections' policy."""
    model = mujoco.MjModel.from_xml_path(str(scene.scene_file(scene.ABDOMEN)))
    return batch_inputs(model, num_envs, steps, seed=0)[1].transpose(1, 0, 2)


def measure_vector(num_envs, steps, runs, bar) -> list[dict]:
    rows = []
    cores = available_cores()
    for backend, workers in [("serial", None), ("threads", 1), ("threads", cores), ("processes", None)]:
        envs = vector.make(TASK, num_envs=num_envs, seed=0, backend=backend, workers=workers)
        actions = smooth_actions(num_envs, steps)
        envs.reset(seed=0)
        envs.step(actions[0])  # warm-up
        seconds = []
        for _ in range(runs):
            envs.reset(seed=0)
            start = time.perf_counter()
            for action in actions:
                envs.step(action)
            seconds.append(time.perf_counter() - start)
            bar.update()
        envs.close()
        name = backend if workers is None else f"{backend}, {workers} worker{'s' if workers > 1 else ''}"
        rows.append({"backend": name, "num_envs": num_envs, "seconds": statistics.median(seconds),
                     "steps_per_s": num_envs * steps / statistics.median(seconds)})
    return rows


TASK_POLICIES = ("scripted", "uniform random", "smooth random")


def measure_tasks(steps, runs, bar) -> list[dict]:
    """Per task and policy: the reset's seconds and env steps per second after it (medians over
    seeds 0 to runs - 1), one serial environment, the policy's own time included."""
    import viscera.tasks
    rows = []
    for task in viscera.tasks.ALL:
        resets, rates = [], {policy: [] for policy in TASK_POLICIES}
        for seed in range(runs):
            env = viscera.tasks.load(task, seed=seed)
            spec = env.action_spec()
            smooth = batch_inputs(env.physics.model.ptr, 1, steps, seed=seed)[1][0]  # this task's tools
            for policy in TASK_POLICIES:
                rng = np.random.RandomState(seed)
                scripted = viscera.tasks.scripted_policy(env) if policy == "scripted" else None
                start = time.perf_counter()
                time_step = env.reset()
                resets.append(time.perf_counter() - start)
                start, done = time.perf_counter(), 0
                for i in range(steps):
                    if time_step.last():
                        break
                    if scripted is not None:
                        action = scripted(time_step)
                    elif policy == "uniform random":
                        action = rng.uniform(spec.minimum, spec.maximum)
                    else:
                        action = smooth[i]
                    time_step = env.step(action)
                    done += 1
                rates[policy].append(done / (time.perf_counter() - start))
            bar.update()
        rows.append({"task": task, "reset_s": statistics.median(resets),
                     "steps_per_s": {policy: statistics.median(r) for policy, r in rates.items()}})
    return rows


def ray_round_trip(runs: int = 200) -> dict:
    """Seconds of an empty actor call and of fetching one trajectory-sized array from an actor."""
    import ray

    @ray.remote(num_cpus=0)
    class Echo:
        def nothing(self):
            return None

        def array(self, size):
            return np.ones(size)

    echo = Echo.remote()
    ray.get(echo.nothing.remote())
    empty = []
    for _ in range(runs):
        start = time.perf_counter()
        ray.get(echo.nothing.remote())
        empty.append(time.perf_counter() - start)
    fetch = []
    size = 1_000_000  # 8 MB: about 2,400 env steps of the clearing task
    for _ in range(20):
        start = time.perf_counter()
        ray.get(echo.array.remote(size))
        fetch.append(time.perf_counter() - start)
    ray.kill(echo)
    return {"empty_call_s": statistics.median(empty), "fetch_8MB_s": statistics.median(fetch),
            "fetch_MB_per_s": 8.0 / statistics.median(fetch)}


def plot(result: dict, path: str) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cores = result["cores"]
    peer = {int(k): v for k, v in result["collect"]["serial_steps_per_s"].items()}
    fig, (rate_axis, eff_axis) = plt.subplots(1, 2, figsize=(10, 4))
    counts = sorted({r["workers"] for r in result["collect"]["rows"] if r["backend"] != "serial"})
    rate_axis.plot(counts, [peer[c] * min(c, cores) for c in counts], "k:",
                   label="ideal: serial x min(workers, cores)")
    for backend, marker in (("threads", "o"), ("processes", "s"), ("ray", "^")):
        rows = [r for r in result["collect"]["rows"] if r["backend"] == backend]
        if not rows:
            continue
        rate_axis.plot([r["workers"] for r in rows], [r["steps_per_s"] for r in rows], marker=marker, label=backend)
        eff_axis.plot([r["workers"] for r in rows], [r["efficiency"] for r in rows], marker=marker, label=backend)
    rate_axis.plot(counts, [peer[c] for c in counts], color="grey", marker=".", lw=0.8, label="serial (same seeds)")
    for axis in (rate_axis, eff_axis):
        axis.axvline(cores, color="grey", ls="--", lw=0.8)
        axis.set_xlabel("workers (dashed: cores)")
        axis.set_xticks(counts)
        axis.legend(fontsize=8)
    rate_axis.set_ylabel("environment steps / s")
    eff_axis.set_ylabel("efficiency (speed-up / workers)")
    eff_axis.set_ylim(0, 1.1)
    fig.suptitle(f"clear_area, {result['envs_per_worker']} envs x {result['steps']} steps per worker, "
                 f"{cores} cores, medians of {result['runs']}")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python python/tools/bench_scale.py", description=__doc__.split("\n")[0])
    parser.add_argument("--workers", type=cli.positive_int, nargs="+", default=None,
                        help="worker counts (default: 1, 2, the cores and twice the cores)")
    parser.add_argument("--envs-per-worker", type=cli.positive_int, default=2,
                        help="environments each worker holds (default 2)")
    parser.add_argument("--steps", type=cli.positive_int, default=100,
                        help="control steps per collection (default 100: 2 s)")
    parser.add_argument("--runs", type=cli.positive_int, default=5,
                        help="timed collections per point, medians (default 5)")
    parser.add_argument("--backends", nargs="+", default=["threads", "processes", "ray"],
                        choices=["threads", "processes", "ray"], help="backends to measure (default: all three)")
    parser.add_argument("--json", type=cli.output_file(".json"), help="write the figures to this JSON file")
    parser.add_argument("--png", type=cli.output_file(".png"),
                        help="draw steps/s and efficiency against workers to this PNG")
    parser.add_argument("--parts", nargs="+", default=["collect", "vector", "tasks"],
                        choices=["collect", "vector", "tasks"],
                        help="what to measure: the backends' scaling, the vector envs, each task (default: all)")
    parser.add_argument("--quiet", action="store_true", help="no progress bars")
    args = parser.parse_args(argv)
    cores = available_cores()
    counts = sorted(set(args.workers or [1, 2, cores, 2 * cores]))
    ray = None
    if "collect" in args.parts and "ray" in args.backends:
        try:
            import ray
        except ImportError:
            parser.error('the ray backend needs Ray: pip install "viscera[ray]" (or leave ray out of --backends)')
    vector_envs = 2 * cores
    import viscera.tasks
    total = ((1 + len(args.backends)) * len(counts) * args.runs if "collect" in args.parts else 0) + \
        (4 * args.runs if "vector" in args.parts else 0) + \
        (len(viscera.tasks.ALL) * args.runs if "tasks" in args.parts else 0)
    result = {"cores": cores, "cpu": cpu_model(), "runs": args.runs, "steps": args.steps,
              "envs_per_worker": args.envs_per_worker}
    with tqdm(total=total, desc="scaling benchmark", disable=args.quiet) as bar:
        if "collect" in args.parts:
            result["collect"] = measure_collect(counts, args.envs_per_worker, args.steps, args.runs, args.backends,
                                                bar)
        if "vector" in args.parts:
            result["vector"] = measure_vector(vector_envs, args.steps, args.runs, bar)
        if "tasks" in args.parts:
            result["tasks"] = measure_tasks(args.steps, args.runs, bar)
    identical = True
    if "collect" in args.parts:
        result["physics_fraction"] = statistics.median(physics_fraction() for _ in range(3))
        result["memory"] = worker_memory()
        if ray is not None:
            result["ray"] = ray_round_trip()
            ray.shutdown()
        collect = result["collect"]
        identical = all(r["identical"] for r in collect["rows"])
        print(f"clear_area, {args.envs_per_worker} envs x {args.steps} control steps per worker, {cores} cores "
              f"({result['cpu']}), medians of {args.runs}; every collection bit-identical to serial: {identical}")
        print(f"{'backend':10s} {'workers':>7s} {'envs':>5s} {'env steps/s':>11s} {'speed-up':>9s} {'efficiency':>10s}")
        for r in collect["rows"]:
            print(f"{r['backend']:10s} {r['workers']:7d} {r['envs']:5d} {r['steps_per_s']:11.1f} "
                  f"{r['speedup']:9.2f} {r['efficiency']:10.2f}")
        print(f"start-up with {max(counts)} workers (s): "
              + ", ".join(f"{b} {s:.2f}" for b, s in collect["startup_s"].items()))
        print(f"physics share of an env step: {result['physics_fraction']:.2f} (the rest is the task's Python); "
              f"a worker process with one env: {result['memory']['process_with_one_env_MB']:.0f} MB, "
              f"{result['memory']['per_further_env_MB']:.1f} MB per further env")
        print(f"trajectory bytes per env step: {collect['bytes_per_step']:.0f} "
              f"(observation of {collect['observation_size']} float64)")
        if "ray" in result:
            print(f"Ray: empty actor call {result['ray']['empty_call_s'] * 1e3:.2f} ms, "
                  f"8 MB fetched from an actor at {result['ray']['fetch_MB_per_s']:.0f} MB/s")
    if "vector" in args.parts:
        print(f"gymnasium vector envs, {vector_envs} envs x {args.steps} steps:")
        for r in result["vector"]:
            print(f"  {r['backend']:22s} {r['steps_per_s']:9.1f} env steps/s")
    if "tasks" in args.parts:
        print(f"per task, one env, serial, {args.steps} control steps after a reset, medians over {args.runs} seeds:")
        print(f"{'task':14s} {'reset s':>8s} " + " ".join(f"{p + ' steps/s':>21s}" for p in TASK_POLICIES))
        for r in result["tasks"]:
            print(f"{r['task']:14s} {r['reset_s']:8.2f} "
                  + " ".join(f"{r['steps_per_s'][p]:21.1f}" for p in TASK_POLICIES))
    if args.json:
        with open(args.json, "w") as out:
            json.dump(result, out, indent=1)
    if args.png and "collect" in args.parts:
        plot(result, args.png)
    return 0 if identical else 1


if __name__ == "__main__":
    raise SystemExit(main())
