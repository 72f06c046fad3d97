"""The collectors behind viscera.scale (its docstring has the backends): workers of one backend
kept between collect calls, the seeds split among them, results back in seed order. The Ray
collector (ray_actors.py) builds on Collector here."""

from __future__ import annotations

import concurrent.futures
import multiprocessing
import threading

import numpy as np

from viscera.checks import checked_integer
from viscera.scale.worker import RolloutWorker, Trajectory, checked_seeds

BACKENDS = ("serial", "threads", "processes", "ray")


def split_seeds(seeds, workers: int) -> list[list[int]]:
    """`workers` contiguous batches of the seeds, sizes differing by at most one (some empty if few seeds)."""
    seeds = checked_seeds(seeds)
    return [list(part) for part in np.array_split(np.asarray(seeds, dtype=np.int64), workers)]


class Collector:
    """Workers of one backend, kept between collect calls; a context manager (close stops them).

    One collection at a time: a worker's environments must never be stepped by two calls
    at once, so a collect() while another runs (another thread, or a collect_as_completed
    iterator not yet exhausted or closed) raises RuntimeError instead.
    """

    backend = "serial"

    def __init__(self, task: str = "clear_area", workers: int = 1, policy="random", task_kwargs: dict | None = None,
                 observation_dtype: str = "float64"):
        workers = checked_integer("workers", workers, 1)
        # refuse a bad task, policy or dtype here rather than in a worker (loads nothing)
        RolloutWorker(task, policy, task_kwargs, observation_dtype)
        self.task, self.workers, self.policy, self.task_kwargs = task, workers, policy, dict(task_kwargs or {})
        self.observation_dtype = observation_dtype
        self._busy = threading.Lock()
        self._closed = False

    def _worker_arguments(self) -> tuple:
        return self.task, self.policy, self.task_kwargs, self.observation_dtype

    def _start(self, seeds, steps) -> tuple[list[int], list]:
        """Checked seeds and the submitted handles; holds the busy lock (released by the caller)."""
        seeds = checked_seeds(seeds)
        steps = checked_integer("steps", steps, 0)
        if self._closed:
            raise RuntimeError(f"this {self.backend} collector is closed")
        if not self._busy.acquire(blocking=False):
            raise RuntimeError("the collector is busy: another collection is running (another thread, or a "
                               "collect_as_completed iterator not yet exhausted or closed)")
        try:
            return seeds, self._submit([b for b in split_seeds(seeds, self.workers) if b], steps)
        except BaseException:
            self._busy.release()
            raise

    def collect(self, seeds, steps: int) -> list[Trajectory]:
        """One trajectory per seed, in the order of `seeds` (see worker.RolloutWorker.run)."""
        seeds, handles = self._start(seeds, steps)
        try:
            trajectories = [t for handle in handles for t in self._result(handle)]
        finally:
            self._wait_all(handles)  # also when a batch failed: the other workers finish first
            self._busy.release()
        if [t.seed for t in trajectories] != seeds:
            raise RuntimeError("the workers returned trajectories out of seed order")  # a bug, never expected
        return trajectories

    def collect_as_completed(self, seeds, steps: int):
        """An iterator over each worker's batch of trajectories (its seeds, in order), as soon as it is done.

        The same trajectories as collect(), in the order the workers finish: a learner can
        start on the first batches while stragglers run. Arguments are checked and the
        batches submitted at the call. Until the iterator is exhausted, closed (close(), a
        with block) or dropped, the collector is busy; closing early waits for the batches in flight.
        """
        return _AsCompleted(self, self._start(seeds, steps)[1])

    # a backend submits batches as handles, then turns a handle into its trajectories
    def _submit(self, batches: list[list[int]], steps: int) -> list:
        raise NotImplementedError

    def _result(self, handle) -> list[Trajectory]:
        raise NotImplementedError

    def _first_done(self, handles: list) -> tuple[object, list]:
        """A finished handle, and the others."""
        return handles[0], handles[1:]

    def _wait_all(self, handles: list) -> None:
        """Return once every handle has finished, failed or not; raises nothing."""

    def close(self) -> None:
        """Stop the workers; collecting afterwards raises RuntimeError."""
        self._closed = True
        self._shutdown()

    def _shutdown(self) -> None:
        pass

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


class _AsCompleted:
    """The iterator of Collector.collect_as_completed: holds the collector's busy lock until closed."""

    def __init__(self, collector: Collector, handles: list):
        self._collector, self._pending, self._open = collector, list(handles), True

    def __iter__(self):
        return self

    def __next__(self) -> list[Trajectory]:
        if not self._pending:
            self.close()
            raise StopIteration
        try:
            done, self._pending = self._collector._first_done(self._pending)
            return self._collector._result(done)
        except BaseException:
            self.close()  # a failed batch: wait for the others, free the collector, then raise
            raise

    def close(self) -> None:
        if self._open:
            self._open = False
            self._collector._wait_all(self._pending)
            self._pending = []
            self._collector._busy.release()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __del__(self):
        self.close()


class SerialCollector(Collector):
    backend = "serial"

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._worker = RolloutWorker(*self._worker_arguments())

    def _submit(self, batches, steps):
        seeds = [s for b in batches for s in b]
        return [self._worker.run(seeds, steps)] if seeds else []  # done already: the handle is the result

    def _result(self, handle):
        return handle


class _PoolCollector(Collector):
    """Workers behind a concurrent.futures executor: handles are futures."""

    def _result(self, handle):
        return handle.result()

    def _first_done(self, handles):
        done = next(concurrent.futures.as_completed(handles))
        return done, [h for h in handles if h is not done]

    def _wait_all(self, handles):
        concurrent.futures.wait(handles)

    def _shutdown(self):
        self._pool.shutdown(wait=True)


class ThreadCollector(_PoolCollector):
    backend = "threads"

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._workers = [RolloutWorker(*self._worker_arguments()) for _ in range(self.workers)]
        self._pool = concurrent.futures.ThreadPoolExecutor(self.workers, thread_name_prefix="viscera-rollout")

    def _submit(self, batches, steps):
        # worker i takes batch i: a worker's environments are never stepped by two threads at once
        return [self._pool.submit(worker.run, batch, steps) for worker, batch in zip(self._workers, batches)]


_process_worker = None  # the RolloutWorker of a collector's worker process


def _start_process_worker(*worker_arguments):
    global _process_worker
    _process_worker = RolloutWorker(*worker_arguments)


def _run_in_process(seeds, steps):
    return _process_worker.run(seeds, steps)


class ProcessCollector(_PoolCollector):
    backend = "processes"

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        # spawn: fresh interpreters, safe beside the parent's threads (MuJoCo's, a learner's)
        self._pool = concurrent.futures.ProcessPoolExecutor(
            self.workers, mp_context=multiprocessing.get_context("spawn"),
            initializer=_start_process_worker, initargs=self._worker_arguments())

    def _submit(self, batches, steps):
        return [self._pool.submit(_run_in_process, batch, steps) for batch in batches]
