"""The task suite's names and gymnasium ids, read from the tasks' own source files.

A task registers itself where it is written, as dm_control's suite does (`@SUITE.add` in
suite/cartpole.py), with a class decorator in its module of viscera/tasks/:

    @base.register("clear_area", "viscera/ClearArea-v0")
    class ClearArea(base.BowelTask):
        ...

Importing that module fills viscera.tasks.base.SUITE, which viscera.tasks.load reads. But
`import viscera` registers the gymnasium ids, and the command line offers the task names,
without loading dm_control (tested: importing viscera imports neither it nor viscera.tasks), so
this module reads the same two literals from the source (Python's ast) instead of importing it;
viscera.tasks then imports exactly the modules found here. No other file lists the tasks: a new
task is one file in viscera/tasks/ (with its scene and its scripted policy).

    tasks()   # task name -> (its module in viscera.tasks, its gymnasium id), in name order
    TASKS     # the same, read on first use
"""

from __future__ import annotations

import ast
import functools
import pathlib

TASKS_FOLDER = pathlib.Path(__file__).resolve().parent / "tasks"
DECORATOR = "register"  # viscera.tasks.base.register


def registrations(source: str, filename: str = "<source>") -> list[tuple[str, str]]:
    """The (name, gymnasium id) of every class decorated `@register("name", "id")` (or
    `@base.register(...)`) in a module's source."""
    found = []
    for node in ast.walk(ast.parse(source, filename)):
        if not isinstance(node, ast.ClassDef):
            continue
        for decorator in node.decorator_list:
            if not isinstance(decorator, ast.Call) or decorator.keywords or len(decorator.args) != 2:
                continue
            callee = decorator.func
            named = callee.attr if isinstance(callee, ast.Attribute) else getattr(callee, "id", None)
            if named == DECORATOR and all(isinstance(a, ast.Constant) and isinstance(a.value, str)
                                          for a in decorator.args):
                found.append((decorator.args[0].value, decorator.args[1].value))
    return found


@functools.cache
def tasks() -> dict[str, tuple[str, str]]:
    """Task name -> (its module in viscera.tasks, its gymnasium id), in name order."""
    found: dict[str, tuple[str, str]] = {}
    for path in sorted(TASKS_FOLDER.glob("*.py")):
        for name, env_id in registrations(path.read_text(), str(path)):
            if name in found:
                raise RuntimeError(f"task {name!r} is registered twice: viscera.tasks.{found[name][0]} and "
                                   f"viscera.tasks.{path.stem}")
            found[name] = (path.stem, env_id)
    return dict(sorted(found.items()))


def __getattr__(name: str):
    if name == "TASKS":  # read on first use: `import viscera` reads no source
        return tasks()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
