"""N viscera task environments stepped together, behind gymnasium's vector-env interface.

    envs = viscera.scale.vector.make("clear_area", num_envs=8, seed=0, backend="threads")
    observations, infos = envs.reset(seed=0)
    observations, rewards, terminations, truncations, infos = envs.step(envs.action_space.sample())

Backends, all with gymnasium's semantics (autoreset on the next step by default,
as CleanRL and gymnasium expect; stable-baselines3 wraps single TaskEnvs instead):
  - "serial":    gymnasium.vector.SyncVectorEnv, one thread;
  - "threads":   ThreadVectorEnv, SyncVectorEnv's semantics with the sub-environments
                 stepped concurrently on `workers` threads. MuJoCo's mj_step releases
                 the GIL, and the physics is most of a control step (about 80 % on the
                 cavity task), so threads run the physics in parallel; the task's Python
                 (observations, reward) takes the GIL in turns;
  - "processes": gymnasium.vector.AsyncVectorEnv, one worker process per environment
                 (started with `spawn`), observations through shared memory; for tasks
                 whose Python share would serialise threads.
Sub-environment i is TaskEnv(task, seed=seed + i); every backend gives the same
observations, rewards and flags bit for bit (tested).
"""

from __future__ import annotations

import concurrent.futures
import functools
from copy import deepcopy

import numpy as np
from gymnasium.vector import AsyncVectorEnv, AutoresetMode, SyncVectorEnv
from gymnasium.vector.utils import concatenate, iterate

from viscera.scale.batch import available_cores
from viscera.scale.gym_env import TaskEnv
from viscera.checks import checked_integer

BACKENDS = ("serial", "threads", "processes")


class ThreadVectorEnv(SyncVectorEnv):
    """SyncVectorEnv whose sub-environments step concurrently on a thread pool (reset, rare, is serial).

    Results, autoreset (an autoreset inside step runs on the pool too) and info batching are
    SyncVectorEnv's: each sub-environment's work is independent, and its results are gathered
    in index order.
    """

    def __init__(self, env_fns, workers: int | None = None, copy: bool = True, observation_mode="same",
                 autoreset_mode: str | AutoresetMode = AutoresetMode.NEXT_STEP):
        if workers is not None:
            workers = checked_integer("workers", workers, 1)  # before any environment is built
        super().__init__(env_fns, copy=copy, observation_mode=observation_mode, autoreset_mode=autoreset_mode)
        self.workers = min(self.num_envs, available_cores()) if workers is None else workers
        self._pool = concurrent.futures.ThreadPoolExecutor(self.workers, thread_name_prefix="viscera-env")

    def _advance(self, i: int, action) -> tuple:
        """Sub-environment i's part of a vector step: (obs, reward, terminated, truncated, info, extra info)."""
        env = self.envs[i]
        if self.autoreset_mode == AutoresetMode.NEXT_STEP and self._autoreset_envs[i]:
            observation, info = env.reset()
            return observation, 0.0, False, False, info, None
        if self.autoreset_mode == AutoresetMode.DISABLED and self._autoreset_envs[i]:
            raise RuntimeError(f"sub-environment {i} ended and autoreset is disabled: reset it first")
        observation, reward, terminated, truncated, info = env.step(action)
        extra = None
        if self.autoreset_mode == AutoresetMode.SAME_STEP and (terminated or truncated):
            extra = {"final_obs": observation, "final_info": info}
            observation, info = env.reset()
        return observation, reward, terminated, truncated, info, extra

    def step(self, actions):
        actions = list(iterate(self.action_space, actions))
        if len(actions) != self.num_envs:  # map() would silently leave the last environments unstepped
            raise ValueError(f"actions hold {len(actions)} actions for {self.num_envs} environments")
        results = list(self._pool.map(self._advance, range(self.num_envs), actions))
        infos = {}
        for i, (observation, reward, terminated, truncated, info, extra) in enumerate(results):
            self._env_obs[i] = observation
            self._rewards[i], self._terminations[i], self._truncations[i] = reward, terminated, truncated
            if extra is not None:
                infos = self._add_info(infos, extra, i)
            infos = self._add_info(infos, info, i)
        self._observations = concatenate(self.single_observation_space, self._env_obs, self._observations)
        self._autoreset_envs = np.logical_or(self._terminations, self._truncations)
        observations = deepcopy(self._observations) if self.copy else self._observations
        return (observations, np.copy(self._rewards), np.copy(self._terminations), np.copy(self._truncations),
                infos)

    def close_extras(self, **kwargs) -> None:
        self._pool.shutdown(wait=True)
        super().close_extras(**kwargs)


def make(task: str = "clear_area", num_envs: int = 2, seed: int | None = 0, backend: str = "threads",
         workers: int | None = None, **env_kwargs):
    """A gymnasium vector env of `num_envs` TaskEnv(task, seed=seed + i, **env_kwargs) (see the module doc).

    seed None leaves every sub-environment unseeded.

    workers: threads for "threads" (default: min(num_envs, cores)); "processes" always
    runs one process per environment and "serial" one thread, so workers must be None there.
    """
    if backend not in BACKENDS:
        raise ValueError(f"backend = {backend!r}: must be one of {BACKENDS}")
    num_envs = checked_integer("num_envs", num_envs, 1)
    if seed is not None:
        seed = checked_integer("seed", seed, 0)
    if workers is not None and backend != "threads":
        raise ValueError(f"workers = {workers}: only the 'threads' backend takes it "
                         f"('{backend}' runs {'one process per environment' if backend == 'processes' else 'one thread'})")
    env_fns = [functools.partial(TaskEnv, task, seed=None if seed is None else seed + i, **env_kwargs)
               for i in range(num_envs)]
    if backend == "serial":
        return SyncVectorEnv(env_fns)
    if backend == "threads":
        return ThreadVectorEnv(env_fns, workers=workers)
    # spawn: a fresh interpreter per worker, safe beside threads (MuJoCo's, a learner's) in the parent
    return AsyncVectorEnv(env_fns, context="spawn")


def make_threads(num_envs: int, task: str = "clear_area", seed: int | None = 0, workers: int | None = None,
                 **env_kwargs) -> ThreadVectorEnv:
    """The registered ids' vector entry point: gymnasium.make_vec(id, num_envs, vectorization_mode=
    "vector_entry_point") gives a ThreadVectorEnv ("sync" and "async" give gymnasium's own)."""
    return make(task, num_envs, seed, "threads", workers, **env_kwargs)
