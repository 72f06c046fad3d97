"""Does a second intestine cost more than its length? Two 2 m instances that fall onto each other
against one 4 m instance, at the same resolution, alternated in one run.

    python python/tools/bench_instances.py [--runs 5] [--duration 3] [--json docs/bench/instances.json]

The loads: each tube laid as a serpentine in the same 0.4 x 0.4 m box 0.1 m above a plane (the 4 m
one in the whole box; the 2 m ones in its lower and upper halves, so the upper falls onto the
lower), 62.5 control points and the default spheres per metre, self-collision on, 2 ms steps.
Printed: each load's median wall seconds per simulated second and the median over runs of the
ratio two instances / one; the ratio near 1 means contacts between instances cost what the same
contacts within one do (the cost stays linear in the total length).
"""

from __future__ import annotations

import argparse
import json
import statistics
import time

import viscera  # first: headless GL backend

import mujoco  # noqa: E402
from tqdm import tqdm  # noqa: E402

from viscera import cli  # noqa: E402

FLOOR = '<geom type="plane" size="3 3 0.1"/>'
BOX = (-0.2, -0.2, 0.1, 0.2, 0.2, 0.5)  # m: min then max corner
POINTS_PER_M = 62.5


def _instance(name: str, length: float, box) -> str:
    whole = viscera.extension_xml(name, length=length, control_points=int(round(POINTS_PER_M * length)),
                                  shape="serpentine", box=list(box))
    return "<instance" + whole.split("<instance", 1)[1].split("</instance>", 1)[0] + "</instance>"


def scene_xml(instances: int) -> str:
    x0, y0, z0, x1, y1, z1 = BOX
    if instances == 1:
        parts = [_instance("gut", 4.0, BOX)]
    else:
        middle = 0.5 * (z0 + z1)
        parts = [_instance("lower", 2.0, (x0, y0, z0, x1, y1, middle)),
                 _instance("upper", 2.0, (x0, y0, middle, x1, y1, z1))]
    return ('<mujoco><option timestep="0.002"/><extension><plugin plugin="viscera.intestine">' + "".join(parts)
            + f"</plugin></extension><worldbody>{FLOOR}</worldbody></mujoco>")


def time_scene(instances: int, duration: float) -> float:
    model = mujoco.MjModel.from_xml_string(scene_xml(instances))
    data = mujoco.MjData(model)
    steps = int(round(duration / model.opt.timestep))
    start = time.perf_counter()
    for _ in range(steps):
        mujoco.mj_step(model, data)
    wall = time.perf_counter() - start
    for gut in viscera.intestines(model):
        if gut.divergence_count(data):
            raise RuntimeError(f"instance {gut.name} diverged")
    return wall / data.time


def run(runs: int = 5, duration: float = 3.0, quiet: bool = False) -> dict:
    samples: dict = {"one 4 m instance": [], "two 2 m instances": []}
    with tqdm(total=2 * runs, desc="runs", disable=quiet) as bar:
        for _ in range(runs):
            for name, count in (("one 4 m instance", 1), ("two 2 m instances", 2)):
                samples[name].append(time_scene(count, duration))
                bar.update(1)
    ratios = [b / a for a, b in zip(samples["one 4 m instance"], samples["two 2 m instances"])]
    return {"runs": runs, "duration_s": duration, "points_per_m": POINTS_PER_M,
            "wall_s_per_sim_s": {name: statistics.median(s) for name, s in samples.items()},
            "ratio_two_over_one": statistics.median(ratios), "ratios": ratios}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=cli.positive_int, default=5, help="alternated runs of each (default 5)")
    parser.add_argument("--duration", type=cli.duration, default=3.0, help="simulated seconds a run (default 3)")
    parser.add_argument("--json", type=cli.output_file(".json"), help="also write the figures to this JSON file")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    args = parser.parse_args(argv)
    results = run(args.runs, args.duration, args.quiet)
    for name, cost in results["wall_s_per_sim_s"].items():
        print(f"{name:20s} {cost:.4f} wall s per sim s")
    print(f"two / one, median of {args.runs} runs' ratios: {results['ratio_two_over_one']:.2f} "
          f"(runs {min(results['ratios']):.2f} to {max(results['ratios']):.2f})")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(results, f, indent=2)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
