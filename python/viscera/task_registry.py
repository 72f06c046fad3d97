"""The task registry: one line per task, read by viscera.tasks (its loaders) and
viscera.gymnasium_ids (its gymnasium ids). Importing it imports nothing else (not
even viscera.tasks), so `import viscera` registers the gymnasium ids without
loading dm_control.

A task is a module of viscera.tasks with a `load(seed=None, **kwargs)` that
returns a dm_env environment and a `scripted_policy(env)`; the tasks share the
abdomen's scene (assets/scenes/abdomen.xml, composed with each task's tools by
viscera.tasks.scene) and its bank of settled starts (every file there ships
with the package).
"""

# task name -> (module in viscera.tasks, gymnasium id)
TASKS = {
    "clear_area": ("clear_area", "viscera/ClearArea-v0"),
    "grasp_lift": ("grasp_lift", "viscera/GraspLift-v0"),
    "run_the_bowel": ("run_the_bowel", "viscera/RunTheBowel-v0"),
    "retract_reach": ("retract_reach", "viscera/RetractReach-v0"),
}
