"""Pictures of each task for docs/tasks.md: its start and the end of its scripted policy's episode
(a success where the policy has one in the first seeds), from the scene's top camera; with
--cavity, the cavity before and after the clearing gesture for docs/cavity.md.

    python python/tools/task_pictures.py [--out docs/tasks] [--tries 12]
    python python/tools/task_pictures.py --cavity [--out docs]
"""

from __future__ import annotations

import argparse
import json
import pathlib


import viscera.tasks
from viscera import cli


def play(task: str, seed: int, out: pathlib.Path) -> dict:
    env = viscera.tasks.load(task, seed=seed)
    policy = viscera.tasks.scripted_policy(env)
    step = env.reset()
    start = env.physics.render(height=360, width=432, camera_id="top")
    while not step.last():
        step = env.step(policy(step))
    success = bool(env.task.success(env.physics))
    cli.save_png(out / f"{task}_start.png", start)
    cli.save_png(out / f"{task}_end.png", env.physics.render(height=360, width=432, camera_id="top"))
    return {"seed": seed, "success": success, "simulated_s": round(float(env.physics.data.time), 2)}


def cavity(out: pathlib.Path, seed: int = 0) -> dict:
    """cavity_before.png and cavity_after.png: clear_area's episode `seed` at its start and after
    the whole gesture (played on past a success, to its time limit: the tools withdrawn)."""
    env = viscera.tasks.load("clear_area", seed=seed, end_on_success=False)
    policy = viscera.tasks.scripted_policy(env)
    step = env.reset()
    cli.save_png(out / "cavity_before.png", env.physics.render(height=480, width=640, camera_id="top"))
    while not step.last():
        step = env.step(policy(step))
    cli.save_png(out / "cavity_after.png", env.physics.render(height=480, width=640, camera_id="top"))
    return {"seed": seed, "uncovered": round(env.task.measurements(env.physics).uncovered_fraction, 3),
            "simulated_s": round(float(env.physics.data.time), 2)}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python python/tools/task_pictures.py", description=__doc__.split("\n")[0])
    parser.add_argument("--out", type=pathlib.Path, help="folder (default docs/tasks; with --cavity, docs)")
    parser.add_argument("--tries", type=cli.positive_int, default=12, help="seeds tried for a success (default 12)")
    parser.add_argument("--cavity", action="store_true", help="the cavity before and after the clearing gesture "
                        "(docs/cavity.md) instead of the tasks' pictures")
    args = parser.parse_args(argv)
    args.out = args.out or pathlib.Path("docs") / ("" if args.cavity else "tasks")
    args.out.mkdir(parents=True, exist_ok=True)
    if args.cavity:
        print("cavity", cavity(args.out))
        return 0
    shown = {}
    for task in viscera.tasks.ALL:
        for seed in range(args.tries):
            shown[task] = play(task, seed, args.out)
            if shown[task]["success"]:
                break
        print(task, shown[task])
    (args.out / "pictures.json").write_text(json.dumps(shown, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
