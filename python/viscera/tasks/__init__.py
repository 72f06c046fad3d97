"""dm_control tasks on the abdominal cavity, loaded by name.

    env = viscera.tasks.load("clear_area", seed=0)   # a dm_env.Environment
    viscera.tasks.ALL                                 # the task names
    policy = viscera.tasks.scripted_policy(env)       # its scripted closed-loop policy
    viscera.tasks.reseed(env, 1)                      # as if loaded with seed 1 (for reused envs)
"""

from __future__ import annotations

import importlib

import numpy as np

from viscera.task_registry import TASKS

ALL = tuple(TASKS)


def load(name: str, seed: int | None = None, **kwargs):
    """The environment called `name` (one of ALL, viscera/task_registry.py), with its random seed."""
    if name not in TASKS:
        raise KeyError(f"unknown task {name!r}; known: {ALL}")
    module = importlib.import_module(f"viscera.tasks.{TASKS[name][0]}")
    return module.load(seed=seed, **kwargs)


def scripted_policy(env):
    """The task's scripted closed-loop policy for `env` (a callable from a dm_env TimeStep to an
    action), working from the observations only."""
    name = type(env.task).__module__.rsplit(".", 1)[-1]
    module = importlib.import_module(f"viscera.tasks.{name}")
    return module.scripted_policy(env)


def reseed(env, seed: int | None) -> None:
    """Give a loaded environment's task the RandomState that load(name, seed) would have given it."""
    env.task._random = np.random.RandomState(seed)  # dm_control tasks draw their episodes from it
