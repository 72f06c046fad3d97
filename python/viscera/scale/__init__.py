"""Collect trajectories of a viscera task on many cores: threads, processes, or Ray across machines.

    trajectories = viscera.scale.collect("clear_area", seeds=range(8), steps=100, workers=2, backend="threads")
    observations, actions, rewards = trajectories[0]      # numpy arrays, see worker.Trajectory

    with viscera.scale.make_collector("ray", "clear_area", workers=64) as collector:   # actors kept
        for iteration in range(1000):
            batch = collector.collect(seeds=range(iteration * 640, (iteration + 1) * 640), steps=50)

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

import concurrent.futures
import multiprocessing

import numpy as np

from viscera.scale.worker import (POLICIES, RandomPolicy, RolloutWorker, Trajectory, checked_integer, checked_seeds,
                                  policy_factory)

BACKENDS = ("serial", "threads", "processes", "ray")

__all__ = ["BACKENDS", "POLICIES", "Collector", "RandomPolicy", "RolloutWorker", "Trajectory", "collect",
           "make_collector", "split_seeds"]


def split_seeds(seeds, workers: int) -> list[list[int]]:
    """`workers` contiguous batches of the seeds, sizes differing by at most one (some empty if few seeds)."""
    seeds = checked_seeds(seeds)
    return [list(part) for part in np.array_split(np.asarray(seeds, dtype=np.int64), workers)]


class Collector:
    """Workers of one backend, kept between collect calls; a context manager (close stops them)."""

    backend = "serial"

    def __init__(self, task: str = "clear_area", workers: int = 1, policy="random", task_kwargs: dict | None = None):
        workers = checked_integer("workers", workers, 1)
        policy_factory(policy)  # refuse a bad policy here, not in a worker
        RolloutWorker(task, policy, task_kwargs)  # and a bad task (loads nothing)
        self.task, self.workers, self.policy, self.task_kwargs = task, workers, policy, dict(task_kwargs or {})

    def collect(self, seeds, steps: int) -> list[Trajectory]:
        """One trajectory per seed, in the order of `seeds` (see worker.RolloutWorker.run)."""
        seeds = checked_seeds(seeds)
        steps = checked_integer("steps", steps, 0)
        batches = [b for b in split_seeds(seeds, self.workers) if b]
        results = self._run(batches, steps)
        trajectories = [t for batch in results for t in batch]
        assert [t.seed for t in trajectories] == seeds
        return trajectories

    def _run(self, batches: list[list[int]], steps: int) -> list[list[Trajectory]]:
        raise NotImplementedError

    def close(self) -> None:
        pass

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


class SerialCollector(Collector):
    backend = "serial"

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._worker = RolloutWorker(self.task, self.policy, self.task_kwargs)

    def _run(self, batches, steps):
        return [self._worker.run([s for b in batches for s in b], steps)]


class ThreadCollector(Collector):
    backend = "threads"

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._workers = [RolloutWorker(self.task, self.policy, self.task_kwargs) for _ in range(self.workers)]
        self._pool = concurrent.futures.ThreadPoolExecutor(self.workers, thread_name_prefix="viscera-rollout")

    def _run(self, batches, steps):
        return list(self._pool.map(lambda w, b: w.run(b, steps), self._workers, batches))

    def close(self):
        self._pool.shutdown(wait=True)


_process_worker = None  # the RolloutWorker of a collector's worker process


def _start_process_worker(task, policy, task_kwargs):
    global _process_worker
    _process_worker = RolloutWorker(task, policy, task_kwargs)


def _run_in_process(seeds, steps):
    return _process_worker.run(seeds, steps)


class ProcessCollector(Collector):
    backend = "processes"

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        # spawn: fresh interpreters, safe beside the parent's threads (MuJoCo's, a learner's)
        self._pool = concurrent.futures.ProcessPoolExecutor(
            self.workers, mp_context=multiprocessing.get_context("spawn"),
            initializer=_start_process_worker, initargs=(self.task, self.policy, self.task_kwargs))

    def _run(self, batches, steps):
        return list(self._pool.map(_run_in_process, batches, [steps] * len(batches)))

    def close(self):
        self._pool.shutdown(wait=True)


def make_collector(backend: str, task: str = "clear_area", workers: int = 1, policy="random",
                   task_kwargs: dict | None = None, **backend_options) -> Collector:
    """A Collector of `backend` (one of BACKENDS); backend_options go to the Ray collector."""
    if backend not in BACKENDS:
        raise ValueError(f"backend = {backend!r}: must be one of {BACKENDS}")
    if backend == "ray":
        from viscera.scale.ray_actors import RayCollector  # Ray is an optional extra
        return RayCollector(task, workers, policy, task_kwargs, **backend_options)
    if backend_options:
        raise ValueError(f"{sorted(backend_options)}: options of the 'ray' backend only")
    cls = {"serial": SerialCollector, "threads": ThreadCollector, "processes": ProcessCollector}[backend]
    return cls(task, workers, policy, task_kwargs)


def collect(task: str, seeds, steps: int, workers: int = 1, backend: str = "serial", policy="random",
            **task_kwargs) -> list[Trajectory]:
    """One trajectory per seed, in seed order: `steps` actions of `policy` from each seed's reset.

    task: a name in viscera.tasks.ALL; task_kwargs go to viscera.tasks.load (time_limit, ...).
    The workers are started and stopped around the call: keep a make_collector(...) to reuse them.
    """
    with make_collector(backend, task, workers, policy, task_kwargs) as collector:
        return collector.collect(seeds, steps)
