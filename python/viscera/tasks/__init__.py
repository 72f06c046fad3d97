"""dm_control tasks on the abdominal cavity, loaded by name.

    env = viscera.tasks.load("clear_area", seed=0)   # a dm_env.Environment
    viscera.tasks.ALL                                 # the task names
"""

from __future__ import annotations

from viscera.tasks import clear_area

_TASKS = {"clear_area": clear_area.load}
ALL = tuple(_TASKS)


def load(name: str, seed: int | None = None, **kwargs):
    """The environment called `name` (one of ALL), with its random seed."""
    if name not in _TASKS:
        raise KeyError(f"unknown task {name!r}; known: {ALL}")
    return _TASKS[name](seed=seed, **kwargs)
