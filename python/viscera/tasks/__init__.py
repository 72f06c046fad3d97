"""dm_control tasks on the abdominal cavity, loaded by name.

    env = viscera.tasks.load("clear_area", seed=0)   # a dm_env.Environment
    env = viscera.tasks.load("clear_area", seed=0, pixels=True, width=84, height=84)  # + camera images
    viscera.tasks.ALL                                 # the task names
    policy = viscera.tasks.scripted_policy(env)       # its scripted closed-loop policy
    viscera.tasks.reseed(env, 1)                      # as if loaded with seed 1 (for reused envs)
"""

from __future__ import annotations

import importlib

import numpy as np

from viscera.checks import checked_bool
from viscera.task_registry import TASKS

ALL = tuple(TASKS)


def load(name: str, seed: int | None = None, pixels: bool = False, width: int = 84, height: int = 84,
         camera: str = "laparoscope", **kwargs):
    """The environment called `name` (one of ALL, viscera/task_registry.py), with its random seed.

    With pixels=True the observations gain `pixels` ((height, width, 3) uint8 RGB), `depth`
    ((height, width) float32, m along the camera's axis) and `segmentation` ((height, width)
    uint8: 0 nothing, 1 intestine, 2 tool, 3 target) from `camera` (viscera.pixels.Camera; the
    intestine is then drawn as 160 capsules: viscera.tasks.base.PIXEL_CAPSULES)."""
    if name not in TASKS:
        raise KeyError(f"unknown task {name!r}; known: {ALL}")
    pixels = checked_bool("pixels", pixels)
    from viscera.pixels import Camera
    observer = Camera(width, height, camera)  # refuses bad sizes before loading, pixels on or off
    if not pixels:
        observer = None
    module = importlib.import_module(f"viscera.tasks.{TASKS[name][0]}")
    env = module.load(seed=seed, **kwargs)
    if observer is not None:
        env.task.observe_pixels(env.physics, observer)
    return env


def close(env) -> None:
    """Free an environment's rendering contexts now (its pixel camera's; else done at garbage
    collection or exit). The environment still works: a later render makes new ones."""
    camera = getattr(env.task, "camera", None)
    if camera is not None:
        camera.close()


def scripted_policy(env):
    """The task's scripted closed-loop policy for `env` (a callable from a dm_env TimeStep to an
    action), working from the observations only."""
    name = type(env.task).__module__.rsplit(".", 1)[-1]
    module = importlib.import_module(f"viscera.tasks.{name}")
    return module.scripted_policy(env)


def reseed(env, seed: int | None) -> None:
    """Give a loaded environment's task the RandomState that load(name, seed) would have given it."""
    env.task._random = np.random.RandomState(seed)  # dm_control tasks draw their episodes from it
