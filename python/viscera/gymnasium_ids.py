"""viscera's gymnasium ids, registered whenever both viscera and gymnasium are imported.

gymnasium 1.x loads no plugins by entry point: an environment package registers
its ids when it is imported (ale_py, shimmy), so that all of these work:

    import gymnasium as gym, viscera
    gym.make("viscera/ClearArea-v0")
    gym.register_envs(viscera)                      # the same, spelled for linters
    gym.make("viscera:viscera/ClearArea-v0")        # gymnasium imports viscera itself

`import viscera` must stay cheap and must not need gymnasium, so it does not
import gymnasium (about 50 ms here): if gymnasium is already imported the ids are
registered at once, otherwise `install()` registers them the moment gymnasium's
own import finishes. The ids are the tasks' own (each task module's
`@base.register(name, id)`), which viscera.task_registry reads from the source, and
entry points are strings, so registering imports neither the tasks nor dm_control;
they load on the first `gym.make`.
"""

from __future__ import annotations

import importlib.abc
import importlib.util
import sys

from viscera import task_registry


def env_ids() -> dict[str, str]:
    """Task name (viscera.tasks.ALL) -> gymnasium id, from the tasks' own registrations."""
    return {task: env_id for task, (_, env_id) in task_registry.tasks().items()}


def __getattr__(name: str):
    if name == "ENV_IDS":  # read on first use: `import viscera` stays cheap
        return env_ids()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def register() -> None:
    """Register the ids of env_ids() with gymnasium (idempotent; imports gymnasium)."""
    import gymnasium
    for task, env_id in env_ids().items():
        if env_id not in gymnasium.registry:
            gymnasium.register(id=env_id, entry_point="viscera.scale.gym_env:TaskEnv",
                               vector_entry_point="viscera.scale.vector:make_threads", kwargs={"task": task})


class _RegisterAfterImport(importlib.abc.MetaPathFinder):
    """Finds gymnasium's own spec and makes its loader call register() once gymnasium has run.

    It stays on sys.meta_path until then: a mere lookup (importlib.util.find_spec, as
    "is it installed" checks do) executes nothing, and the import that follows must
    still be caught.
    """

    def find_spec(self, fullname, path=None, target=None):
        if fullname != "gymnasium":
            return None
        spec = None
        for finder in sys.meta_path:  # the others, in order: what the import would find without us
            find = getattr(finder, "find_spec", None)
            if finder is not self and find is not None:
                spec = find(fullname, path, target)
                if spec is not None:
                    break
        if spec is None or spec.loader is None:
            return spec  # not installed: the import fails as it would without viscera
        loader = spec.loader
        exec_module = loader.exec_module

        def exec_then_register(module):
            exec_module(module)
            if self in sys.meta_path:
                sys.meta_path.remove(self)
            register()

        # on this one loader instance only: spec.loader stays gymnasium's own (resources, reload)
        loader.exec_module = exec_then_register
        return spec


def install() -> None:
    """Register now if gymnasium is imported, else as soon as it is (called by `import viscera`)."""
    if sys.modules.get("gymnasium") is not None:
        register()
    elif not any(isinstance(finder, _RegisterAfterImport) for finder in sys.meta_path):
        sys.meta_path.insert(0, _RegisterAfterImport())
