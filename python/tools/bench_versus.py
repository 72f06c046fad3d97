"""Two builds of viscera against each other, alternated in one run: is this one slower?

    python python/tools/bench_versus.py OTHER_PYTHON [--pairs 6] [--duration 10] [--json out.json]

OTHER_PYTHON is the interpreter of a second environment with another build installed, e.g. the
previous commit:

    git worktree add /tmp/previous HEAD~1 && python -m venv /tmp/previous-venv
    /tmp/previous-venv/bin/pip install /tmp/previous
    python python/tools/bench_versus.py /tmp/previous-venv/bin/python

Each pair times both builds in turn, in fresh processes, on the same work, with this checkout's
benchmark code (only the installed library differs): the cavity under bench_cavity.py's vigorous
sweep (every actuator on a sine), the cavity at rest (every control 0 from the scene's settled
start: the pile resting, the tools still) and bench_fall.py's fall (the paper's 250-point tube
dropped on a plane, self-collision on). The cavity is the shipped box abdomen, or the scene file
--scene names (both builds must load it: to compare a release with a later one on the anatomical
abdomen, give the release's own scene, `git show v:assets/scenes/abdomen_anatomical.xml`).
Printed: each build's median wall seconds per simulated second, and the median over pairs of this
build's time over the other's (below 1: this one is faster). Alternating pairs lets a machine's
drift hit both alike.
"""

from __future__ import annotations

import argparse
import json
import pathlib
import statistics
import subprocess
import sys

from tqdm import tqdm

from viscera import cli

HERE = pathlib.Path(__file__).resolve().parent

# each load: a program printing one number, wall seconds per simulated second
LOADS = {
    "cavity sweep": """
import sys; sys.path.insert(0, {tools!r})
import mujoco, bench_cavity
model = mujoco.MjModel.from_xml_string(bench_cavity.variant_xml("full", {scene_text!r}))
controls = bench_cavity.sweep_controls(model, {duration})
print(bench_cavity.time_replay(model, controls).sum() / (len(controls) * model.opt.timestep))
""",
    "cavity rest": """
import sys; sys.path.insert(0, {tools!r})
import mujoco, numpy as np, bench_cavity
model = mujoco.MjModel.from_xml_string(bench_cavity.variant_xml("full", {scene_text!r}))
controls = np.zeros((int(round({duration} / model.opt.timestep)), model.nu))
print(bench_cavity.time_replay(model, controls).sum() / (len(controls) * model.opt.timestep))
""",
    "fall": """
import sys; sys.path.insert(0, {tools!r})
import mujoco, bench_fall
model = mujoco.MjModel.from_xml_string(bench_fall.viscera_xml())
print(bench_fall._time_model(model, {duration})[0])
""",
}


def run_once(python: str, load: str, duration: float, scene_text: str | None = None) -> float:
    program = LOADS[load].format(tools=str(HERE), duration=duration, scene_text=scene_text)
    result = subprocess.run([python, "-c", program], capture_output=True, text=True, check=True)
    return float(result.stdout.split()[-1])


def run(other: str, pairs: int = 6, duration: float = 10.0, quiet: bool = False, scene_file: str | None = None,
        loads: tuple = tuple(LOADS)) -> dict:
    scene_text = pathlib.Path(scene_file).read_text() if scene_file else None
    samples = {load: {"this": [], "other": []} for load in loads}
    with tqdm(total=pairs * len(loads) * 2, desc="runs", disable=quiet) as bar:
        for pair in range(pairs):
            for load in loads:
                order = (("this", sys.executable), ("other", other))
                for name, python in order if pair % 2 == 0 else order[::-1]:  # who goes first alternates too
                    samples[load][name].append(run_once(python, load, duration, scene_text))
                    bar.update(1)
    results = {"pairs": pairs, "duration_s": duration, "scene": scene_file or "the box abdomen", "loads": {}}
    for load, s in samples.items():
        ratios = [a / b for a, b in zip(s["this"], s["other"])]
        results["loads"][load] = {"this_wall_s_per_sim_s": statistics.median(s["this"]),
                                  "other_wall_s_per_sim_s": statistics.median(s["other"]),
                                  "ratio_median": statistics.median(ratios), "ratios": ratios}
    return results


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python python/tools/bench_versus.py", description=__doc__.split("\n")[0])
    parser.add_argument("other", type=cli.input_file, help="the other environment's python")
    parser.add_argument("--pairs", type=cli.positive_int, default=6, help="alternated pairs of runs (default 6)")
    parser.add_argument("--duration", type=cli.duration, default=10.0,
                        help="simulated seconds of each run (default 10)")
    parser.add_argument("--scene", type=cli.input_file, help="the cavity's scene file (default: the shipped box "
                        "abdomen)")
    parser.add_argument("--loads", nargs="+", choices=list(LOADS), default=list(LOADS),
                        help="which loads (default: all)")
    parser.add_argument("--json", type=cli.output_file(".json"), help="also write the figures to this JSON file")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    args = parser.parse_args(argv)
    results = run(args.other, args.pairs, args.duration, args.quiet, args.scene, tuple(args.loads))
    for load, r in results["loads"].items():
        print(f"{load:<14} this {r['this_wall_s_per_sim_s']:.4f}, other {r['other_wall_s_per_sim_s']:.4f} wall s per "
              f"sim s; this / other, median of {args.pairs} pairs: {r['ratio_median']:.3f} "
              f"(pairs {min(r['ratios']):.3f} to {max(r['ratios']):.3f})")
    if args.json:
        pathlib.Path(args.json).write_text(json.dumps(results, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
