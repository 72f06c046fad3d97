"""The task registry: one line per task, read by viscera.tasks (its loaders) and
viscera.gymnasium_ids (its gymnasium ids). Importing it imports nothing else (not
even viscera.tasks), so `import viscera` registers the gymnasium ids without
loading dm_control.

A task is a module of viscera.tasks with a `load(seed=None, **kwargs)` that
returns a dm_env environment, and its scene under assets/scenes/ (every scene
there ships with the package).
"""

# task name -> (module in viscera.tasks, gymnasium id)
TASKS = {
    "clear_area": ("clear_area", "viscera/ClearArea-v0"),
}
