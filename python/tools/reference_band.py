"""The reference band: the scripted policies' scores on unseen seeds, per task, against which a
trainee's score is read (docs/rehearsal.md), as LAP Mentor shows a trainee the best quartile.

    python python/tools/reference_band.py [--seeds 50] [--first-seed 1000] [--tasks ...]
        [--workers 2] [--json docs/rehearsal/band.json]

Each episode is recorded (viscera.recording.record, scripted policy) and scored while it runs
(viscera.assess). The bands alone also go to assets/scenes/reference_band.json, which the
package installs for `python -m viscera report`. The seeds start at 1000: the scripts were tuned on seeds below 200. Per task
and figure the JSON holds the quartiles and the best quartile's bound (the 25th percentile for
figures where less is better), over the episodes; every episode's score is kept too.
"""

from __future__ import annotations

import argparse
import concurrent.futures
import json
import os
import pathlib

import numpy as np
from tqdm import tqdm

import viscera.tasks
from viscera import assess, cli, recording

OUT = pathlib.Path("docs") / "rehearsal" / "band.json"
FIGURES = assess.BAND_FIGURES
PACKAGED = pathlib.Path("assets") / "scenes" / "reference_band.json"  # the bands alone, installed with the package


def episode(task: str, seed: int) -> dict:
    tracer = []

    def on_step(env, time_step) -> None:
        if not tracer:
            tracer.append(assess.Tracer(env))
        tracer[0].sample(env)

    made = recording.record(task, seed, "scripted", on_step=on_step)
    return {"task": task, "seed": seed, "score": assess.score(tracer[0].trace), "success": made.success}


def band(rows: list[dict]) -> dict:
    out = {"episodes": len(rows), "success_rate": float(np.mean([r["success"] for r in rows])), "figures": {}}
    for name, read, unit in FIGURES:
        values = np.array([read(r["score"]) for r in rows], dtype=float)
        q1, median, q3 = np.percentile(values, [25, 50, 75])
        out["figures"][name] = {"unit": unit, "q1": float(q1), "median": float(median), "q3": float(q3),
                                "best_quartile_bound": float(q1)}
    return out


def compact(result: dict) -> dict:
    """The band without its episodes: what `python -m viscera report` draws against (PACKAGED)."""
    return {"source": str(OUT), "seeds": result["seeds"], "policy": result["policy"], "tasks": result["tasks"]}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python python/tools/reference_band.py",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=cli.positive_int, default=50, help="episodes per task (default 50)")
    parser.add_argument("--first-seed", type=cli.natural_int, default=1000, help="the first seed (default 1000)")
    parser.add_argument("--tasks", nargs="+", choices=viscera.tasks.ALL, default=list(viscera.tasks.ALL),
                        help="the tasks (default: all)")
    parser.add_argument("--workers", type=cli.positive_int, default=os.cpu_count(), help="worker processes")
    parser.add_argument("--json", type=cli.output_file(".json"), default=str(OUT), help=f"output (default {OUT})")
    args = parser.parse_args(argv)
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    jobs = [(task, seed) for task in args.tasks for seed in seeds]
    with concurrent.futures.ProcessPoolExecutor(args.workers) as pool:
        rows = list(tqdm(pool.map(episode, *zip(*jobs)), total=len(jobs), desc="episodes"))
    result = {"seeds": [seeds.start, seeds.stop - 1], "policy": "scripted",
              "tasks": {task: band([r for r in rows if r["task"] == task]) for task in args.tasks},
              "episodes": rows}
    pathlib.Path(args.json).parent.mkdir(parents=True, exist_ok=True)
    pathlib.Path(args.json).write_text(json.dumps(result, indent=1))
    if pathlib.Path(args.json).resolve() == OUT.resolve():  # the committed band: the package's copy too
        PACKAGED.write_text(json.dumps(compact(result), indent=1) + "\n")
    for task, b in result["tasks"].items():
        f = b["figures"]
        print(f"{task:14s} success {b['success_rate']:.0%}, time {f['time_s']['median']:.1f} s, path "
              f"{f['path_length_m']['median']:.2f} m, peak force {f['peak_force_n']['median']:.2f} N")


if __name__ == "__main__":
    main()
