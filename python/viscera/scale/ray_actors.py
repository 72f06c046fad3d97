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

The collector waits until every actor has started, at most `start_timeout` s:
actors that find no free CPUs (more than the cluster has, or a cluster busy with
other work) would otherwise queue, and collect() would wait forever. Then it
stops the actors it started and raises TimeoutError with the CPUs the cluster has
and has free. An autoscaling cluster needs a start_timeout long enough to add nodes.

viscera, with its built plugin, must be installed in the same Python environment
on every node (the cluster's image, or Ray's runtime_env with a viscera wheel).

A lost actor (its process or node died) is restarted by Ray up to `max_restarts`
times and its call retried: a trajectory depends only on its seed, so the retried
batch is bit-identical to the lost one (tested by killing an actor).
"""

from __future__ import annotations

from viscera.scale.collectors import Collector
from viscera.checks import checked_integer
from viscera.scale.worker import RolloutWorker

try:
    import ray
except ImportError as error:  # an optional extra
    raise ImportError('the "ray" backend needs Ray: pip install "viscera[ray]"') from error


class RayCollector(Collector):
    backend = "ray"

    def __init__(self, task: str = "clear_area", workers: int = 1, policy="random", task_kwargs: dict | None = None,
                 observation_dtype: str = "float64", cpus_per_worker: float = 1.0, ray_init: dict | None = None, max_restarts: int = 3,
                 start_timeout: float = 120.0):
        super().__init__(task, workers, policy, task_kwargs, observation_dtype)
        if not (isinstance(cpus_per_worker, (int, float)) and cpus_per_worker > 0):
            raise ValueError(f"cpus_per_worker = {cpus_per_worker!r}: must be a positive number")
        max_restarts = checked_integer("max_restarts", max_restarts, 0)
        if not (isinstance(start_timeout, (int, float)) and start_timeout > 0):
            raise ValueError(f"start_timeout = {start_timeout!r}: must be a positive number of seconds")
        if not ray.is_initialized():
            ray.init(**(ray_init or {}))
        actor = ray.remote(num_cpus=cpus_per_worker, max_restarts=max_restarts,
                           max_task_retries=max_restarts)(RolloutWorker)
        self._actors = [actor.remote(*self._worker_arguments()) for _ in range(self.workers)]
        started = [a.ready.remote() for a in self._actors]
        _, pending = ray.wait(started, num_returns=len(started), timeout=start_timeout)
        if pending:
            total, free = ray.cluster_resources().get("CPU", 0.0), ray.available_resources().get("CPU", 0.0)
            self.close()
            raise TimeoutError(
                f"workers = {self.workers}: {len(pending)} of {self.workers} Ray actors did not start within "
                f"start_timeout = {start_timeout:g} s; each needs cpus_per_worker = {cpus_per_worker:g} CPUs, "
                f"the cluster has {total:g} CPUs and {free:g} free")
        ray.get(started)  # an actor that failed to construct raises here

    def _submit(self, batches, steps):
        return [actor.run.remote(batch, steps) for actor, batch in zip(self._actors, batches)]

    def _result(self, handle):
        return ray.get(handle)

    def _first_done(self, handles):
        done, rest = ray.wait(handles, num_returns=1)
        return done[0], rest

    def _wait_all(self, handles):
        if handles:
            ray.wait(handles, num_returns=len(handles))

    def _shutdown(self):
        for actor in self._actors:
            ray.kill(actor)
        self._actors = []
