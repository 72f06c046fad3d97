"""Pictures of each task for docs/tasks.md: its start and the end of its scripted policy's episode
(a success where the policy has one in the first seeds), from the scene's top camera.

    python python/tools/task_pictures.py [--out docs/tasks] [--tries 12]
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


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python python/tools/task_pictures.py", description=__doc__.split("\n")[0])
    parser.add_argument("--out", type=pathlib.Path, default=pathlib.Path("docs") / "tasks", help="folder (default docs/tasks)")
    parser.add_argument("--tries", type=cli.positive_int, default=12, help="seeds tried for a success (default 12)")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
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
