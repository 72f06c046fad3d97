"""Collect trajectories of a viscera task on many cores: threads, processes, or Ray across machines.

    trajectories = viscera.scale.collect("clear_area", seeds=range(8), steps=100, workers=2, backend="threads")
    observations, actions, rewards = trajectories[0]      # numpy arrays, see worker.Trajectory

    with viscera.scale.make_collector("ray", "clear_area", workers=64) as collector:   # actors kept
        for iteration in range(1000):
            batch = collector.collect(seeds=range(iteration * 640, (iteration + 1) * 640), steps=50)
            # or, batch by batch as the workers finish: collector.collect_as_completed(seeds, steps)

`workers` RolloutWorkers (worker.py) each hold their own environments; the seeds
are split into `workers` contiguous batches, one per worker, and the results come
back in seed order. Backends:
  - "serial":    one worker in the calling thread, whatever `workers` says (the reference);
  - "threads":   one worker per thread in this process; MuJoCo releases the GIL in
                 mj_step, which is most of a control step, so the physics runs in parallel;
  - "processes": one worker per process (spawned), kept for the collector's life;
  - "ray":       one worker per Ray actor (ray_actors.py), on the Ray cluster the process
                 is connected to (ray.init() first; else a local Ray is started). Needs
                 the optional extra: pip install "viscera[ray]".
Every backend returns bit-identical trajectories for the same seeds (tested).
"""

from __future__ import annotations

from viscera.scale.collectors import (BACKENDS, Collector, ProcessCollector, SerialCollector, ThreadCollector,
                                      split_seeds)
from viscera.scale.worker import POLICIES, RandomPolicy, RolloutWorker, Trajectory

__all__ = ["BACKENDS", "POLICIES", "Collector", "RandomPolicy", "RolloutWorker", "Trajectory", "collect",
           "make_collector", "split_seeds"]


def make_collector(backend: str, task: str = "clear_area", workers: int = 1, policy="random",
                   task_kwargs: dict | None = None, observation_dtype: str = "float64",
                   **backend_options) -> Collector:
    """A Collector of `backend` (one of BACKENDS); backend_options go to the Ray collector."""
    if backend not in BACKENDS:
        raise ValueError(f"backend = {backend!r}: must be one of {BACKENDS}")
    if backend == "ray":
        from viscera.scale.ray_actors import RayCollector  # Ray is an optional extra
        return RayCollector(task, workers, policy, task_kwargs, observation_dtype, **backend_options)
    if backend_options:
        raise ValueError(f"{sorted(backend_options)}: options of the 'ray' backend only")
    cls = {"serial": SerialCollector, "threads": ThreadCollector, "processes": ProcessCollector}[backend]
    return cls(task, workers, policy, task_kwargs, observation_dtype)


def collect(task: str, seeds, steps: int, workers: int = 1, backend: str = "serial", policy="random",
            observation_dtype: str = "float64", **task_kwargs) -> list[Trajectory]:
    """One trajectory per seed, in seed order: `steps` actions of `policy` from each seed's reset.

    task: a name in viscera.tasks.ALL; task_kwargs go to viscera.tasks.load (time_limit,
    axis_samples, ...); observation_dtype "float32" halves the observations' bytes.
    The workers are started and stopped around the call: keep a make_collector(...) to reuse them.
    """
    with make_collector(backend, task, workers, policy, task_kwargs, observation_dtype) as collector:
        return collector.collect(seeds, steps)
