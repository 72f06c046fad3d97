"""dm_control tasks on the abdominal cavity, loaded by name.

    env = viscera.tasks.load("clear_area", seed=0)   # a dm_env.Environment
    env = viscera.tasks.load("clear_area", seed=0, pixels=True, width=84, height=84)  # + camera images
    viscera.tasks.ALL                                 # the task names
    policy = viscera.tasks.scripted_policy(env)       # its scripted oracle (viscera.tasks.oracle)
    decision = policy.decide(time_step.observation)   # the action, phase, lead tool and aims
    viscera.tasks.reseed(env, 1)                      # as if loaded with seed 1 (for reused envs)

A task is one module of this folder, its class registered where it is written
(`@base.register(name, gymnasium_id)`, viscera.tasks.base says what a task defines). Importing
this package imports every module that registers one (found by viscera.task_registry, which reads
the decorators from the source), and one factory, viscera.tasks.base.build, builds any of them.
How often each scripted policy succeeds is measured in docs/tasks/rates.json
(python python/tools/task_rates.py).
"""

from __future__ import annotations

import importlib

from viscera import task_registry
from viscera.checks import checked_bool
from viscera.tasks import base

ALL = tuple(task_registry.tasks())  # the names, in name order
for _module in sorted({module for module, _ in task_registry.tasks().values()}):
    importlib.import_module(f"{__name__}.{_module}")  # each registers its tasks in base.SUITE
del _module
_unread = sorted(name for name, task in base.SUITE.items()
                 if name not in ALL and task.__module__.startswith(f"{__name__}."))
if _unread:  # registered with other than string literals: no gymnasium id, not in ALL
    raise RuntimeError(f"viscera.tasks: task_registry cannot read the registration of {_unread}; write "
                       "@base.register(\"name\", \"viscera/Name-v0\") with string literals")


def load(name: str, seed: int | None = None, pixels: bool = False, width: int = 84, height: int = 84,
         camera: str = "laparoscope", **kwargs):
    """The environment called `name` (one of ALL), with its random seed; `kwargs` go to
    viscera.tasks.base.build: time_limit, control_timestep, axis_samples, randomize, and the
    task's own options (clear_area's end_on_success).

    With pixels=True the observations gain `pixels` ((height, width, 3) uint8 RGB), `depth`
    ((height, width) float32, m along the camera's axis) and `segmentation` ((height, width)
    uint8: 0 nothing, 1 intestine, 2 tool, 3 target) from `camera` (viscera.pixels.Camera; the
    intestine is then drawn as 160 capsules per 3 m: viscera.tasks.base.PIXEL_CAPSULES)."""
    if name not in base.SUITE:
        raise KeyError(f"unknown task {name!r}; known: {ALL}")
    pixels = checked_bool("pixels", pixels)
    from viscera.pixels import Camera
    observer = Camera(width, height, camera)  # refuses bad sizes before loading, pixels on or off
    env = base.build(base.SUITE[name], seed=seed, **kwargs)
    if pixels:
        env.task.observe_pixels(env.physics, observer)
    return env


def close(env) -> None:
    """Free an environment's rendering contexts now (its pixel camera's; else done at garbage
    collection or exit). The environment still works: a later render makes new ones."""
    camera = getattr(env.task, "camera", None)
    if camera is not None:
        camera.close()


def scripted_policy(env):
    """The task's scripted oracle for `env` (viscera.tasks.oracle.Oracle: a callable from a dm_env
    TimeStep to an action, and `decide(observation)` for the action with its phase, lead tool and
    aims), deciding every step from the observation alone: its class's POLICY."""
    return env.task.scripted_policy(env)


def oracle_phases(name: str) -> tuple[str, ...]:
    """The phases task `name`'s scripted oracle names (viscera.tasks.oracle.Decision.phase): what a
    dataset's `oracle.phase` indexes."""
    if name not in base.SUITE:
        raise KeyError(f"unknown task {name!r}; known: {ALL}")
    return tuple(base.SUITE[name].POLICY.PHASES)


def reseed(env, seed: int | None) -> None:
    """Give a loaded environment's task the RandomState that load(name, seed) would have given it."""
    env.task.reseed(seed)
