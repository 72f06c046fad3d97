"""Episodes per hour per core that `python -m viscera dataset` collects and writes, per task and
format, with pixels on and off; written to docs/learning/dataset_speed.json.

    python python/tools/learning/dataset_speed.py [--episodes 4] [--runs 3] [--tasks ...] [--out docs/learning/dataset_speed.json]

One worker (this process collects and writes), the scripted demonstrator on seeds 0 to EPISODES -
1; pixels are the laparoscope's 84 x 84 RGB, depth and segmentation. The rate is over the
process's CPU time (all its threads: LeRobot's video encoder runs two), so other work on the
machine does not skew it. Each configuration runs --runs times, alternated, and the median is
kept.
"""

from __future__ import annotations

import argparse
import json
import pathlib
import sys
import tempfile
import time

import numpy as np
from tqdm import tqdm

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import common  # noqa: E402

OUT = pathlib.Path("docs") / "learning" / "dataset_speed.json"
TASKS = ("clear_area", "grasp_lift", "retract_reach", "run_the_bowel")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python python/tools/learning/dataset_speed.py", description=__doc__.split("\n\n")[0])
    parser.add_argument("--episodes", type=int, default=4, help="episodes per dataset (default 4)")
    parser.add_argument("--runs", type=int, default=3, help="runs of each configuration, alternated (default 3)")
    parser.add_argument("--tasks", nargs="+", choices=TASKS, default=list(TASKS), help="default: all four")
    parser.add_argument("--formats", nargs="+", choices=("lerobot", "minari"), default=["lerobot", "minari"],
                        help="default: both")
    parser.add_argument("--out", type=pathlib.Path, default=OUT, help=f"the results JSON (default {OUT})")
    args = parser.parse_args(argv)

    from viscera import datasets

    configurations = [(task, format, pixels) for task in args.tasks for format in args.formats
                      for pixels in (False, True)]
    rates = {c: [] for c in configurations}
    frames = {}
    with tqdm(total=len(configurations) * args.runs, unit="dataset") as bar:
        for _ in range(args.runs):
            for task, format, pixels in configurations:
                with tempfile.TemporaryDirectory() as folder:
                    cpu = time.process_time()
                    summary = datasets.write(task, pathlib.Path(folder) / "d", format, seeds=range(args.episodes),
                                             pixels=pixels, workers=1)
                    cpu_s = time.process_time() - cpu
                rates[(task, format, pixels)].append(summary["episodes"] / (cpu_s / 3600.0))
                frames[(task, format, pixels)] = summary["frames"] / summary["episodes"]
                bar.update()
    rows = [{"task": task, "format": format, "pixels": pixels, "episodes_per_hour_per_core": float(np.median(r)),
             "runs": r, "mean_frames_per_episode": frames[(task, format, pixels)]}
            for (task, format, pixels), r in rates.items()]
    record = {"episodes_per_run": args.episodes, "workers": 1, "clock": "process CPU time", "image_size": [84, 84], "rows": rows,
              "versions": common.versions("lerobot", "minari")}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(record, indent=1) + "\n")
    for row in rows:
        print(f"{row['task']:>14} {row['format']:>8} pixels {'on ' if row['pixels'] else 'off'} "
              f"{row['episodes_per_hour_per_core']:8.0f} episodes/hour/core")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
