"""Rollout workers as Ray actors: the same code on a laptop's local Ray and on a cluster.

    import ray
    ray.init(address="auto")                      # a cluster; or ray.init(num_cpus=2) locally
    with viscera.scale.make_collector("ray", "clear_area", workers=64) as collector:
        trajectories = collector.collect(seeds=range(640), steps=100)

Each actor is a viscera.scale.RolloutWorker reserving `cpus_per_worker` CPUs
(default 1: one environment batch per core, MuJoCo stepping on the actor's
thread). Trajectories come back as numpy arrays through Ray's object store
(zero-copy pickling of the arrays). If Ray is not connected when the collector
starts, a local Ray is started with `ray_init` as ray.init's arguments.

Asking for more actors than the cluster has CPUs is refused up front: Ray would
otherwise queue the actors that do not fit and collect() would wait forever.

A lost actor (its process or node died) is restarted by Ray up to `max_restarts`
times and its call retried: a trajectory depends only on its seed, so the retried
batch is bit-identical to the lost one (tested by killing an actor).
"""

from __future__ import annotations

from viscera.scale import Collector
from viscera.scale.worker import RolloutWorker

try:
    import ray
except ImportError as error:  # an optional extra
    raise ImportError('the "ray" backend needs Ray: pip install "viscera[ray]"') from error


class RayCollector(Collector):
    backend = "ray"

    def __init__(self, task: str = "clear_area", workers: int = 1, policy="random", task_kwargs: dict | None = None,
                 cpus_per_worker: float = 1.0, ray_init: dict | None = None, max_restarts: int = 3):
        super().__init__(task, workers, policy, task_kwargs)
        if not cpus_per_worker > 0:
            raise ValueError(f"cpus_per_worker = {cpus_per_worker}: must be positive")
        if not ray.is_initialized():
            ray.init(**(ray_init or {}))
        cpus = ray.cluster_resources().get("CPU", 0.0)
        if self.workers * cpus_per_worker > cpus:
            raise ValueError(f"workers = {self.workers} at cpus_per_worker = {cpus_per_worker} needs "
                             f"{self.workers * cpus_per_worker:g} CPUs; the Ray cluster has {cpus:g}")
        actor = ray.remote(num_cpus=cpus_per_worker, max_restarts=max_restarts,
                           max_task_retries=max_restarts)(RolloutWorker)
        self._actors = [actor.remote(self.task, self.policy, self.task_kwargs) for _ in range(self.workers)]

    def _run(self, batches, steps):
        return ray.get([actor.run.remote(batch, steps) for actor, batch in zip(self._actors, batches)])

    def close(self):
        for actor in self._actors:
            ray.kill(actor)
        self._actors = []
