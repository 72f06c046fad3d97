"""What one substep costs the anatomical abdomen: stability under the sweep, sleep after it, and the
fall's accuracy against an 8-substep reference.

    python python/tools/one_substep.py [--sweeps 4 8 12 16 20] [--rest 5] [--json docs/bench/one_substep.json]

The leapfrog kick takes the global length term, the small bowel's stiffest elastic mode,
implicitly (plugin/core/src/vsc_schemes.c), and the contact pass holds a pile's damping to
gamma h = 0.9 (plugin/core/src/vsc_contact_load.h). With them the stability estimate gives the
anatomical small bowel one substep per 1 ms step, where it gave two. Measured here, each with the plugin's own substeps (no `substeps` key):
  - substeps: what each shipped scene's intestines take per step (`stability()`);
  - sweep: the anatomical abdomen under bench_cavity.py's vigorous sweep (every actuator on a
    sine) for each of --sweeps seconds, each run from the scene's start: the divergence
    recoveries and failures during it; then --rest seconds with every control 0 (the tools
    withdrawn and still): the share of the small bowel's control points asleep at each second,
    and the recoveries at rest. Where a sweep stops changes the pile it leaves, so several are
    run; the median is what to quote;
  - fall: the paper's fall (fall_on_plane.xml: a 4 m, 250-point tube dropped 0.1 m onto a
    plane, 2 ms steps) for 0.5 s against the same with 8 substeps a step: the largest distance
    between the two tubes' centroids, and the largest mean distance of their axis points,
    sampled every 10 ms. After the impact the two tubes part by several millimetres whatever
    the substeps (8 against 16 substeps already do), so the centroid is the figure to compare.
Runs on any build whose Python API has `stability()`, `recovery_count()` and `asleep()`, so the
same script measures an older build installed in another environment.
"""

from __future__ import annotations

import argparse
import json
import pathlib
import statistics
import time

import viscera  # first: headless GL backend

import mujoco  # noqa: E402
import numpy as np  # noqa: E402
from tqdm import tqdm  # noqa: E402

import bench_cavity  # noqa: E402
from viscera import cli  # noqa: E402
from viscera.tasks import scene  # noqa: E402

SCENE_FILES = {"fall": "fall_on_plane.xml", "box abdomen": scene.ABDOMEN,
               "anatomical abdomen": scene.SCENES["anatomical"].file}


def substeps() -> dict:
    """Each shipped scene's intestines: their stability estimate and the substeps they take."""
    out = {}
    for name, file in SCENE_FILES.items():
        model = mujoco.MjModel.from_xml_path(str(scene.scene_file(file)))
        out[name] = {"timestep_s": model.opt.timestep,
                     "intestines": [gut.stability() for gut in viscera.intestines(model)]}
    return out


def sweep_then_rest(sweep_s: float, rest_s: float) -> dict:
    """The anatomical abdomen swept for sweep_s, then resting for rest_s."""
    model = mujoco.MjModel.from_xml_path(str(scene.scene_file(SCENE_FILES["anatomical abdomen"])))
    data = mujoco.MjData(model)
    bowel = viscera.intestines(model)[0]
    start = time.perf_counter()
    for control in bench_cavity.sweep_controls(model, sweep_s):
        data.ctrl[:] = control
        mujoco.mj_step(model, data)
    wall = time.perf_counter() - start
    swept = {"recoveries": bowel.recovery_count(data), "failures": bowel.divergence_count(data)}
    data.ctrl[:] = 0.0
    asleep = []
    per_second = int(round(1.0 / model.opt.timestep))
    for step in range(int(round(rest_s / model.opt.timestep))):
        mujoco.mj_step(model, data)
        if (step + 1) % per_second == 0:
            asleep.append(float(np.mean(bowel.asleep(data) > 0)))
    return {"sweep_s": sweep_s, "sweep_wall_s_per_sim_s": wall / sweep_s,
            "sweep_recoveries": swept["recoveries"], "sweep_failures": swept["failures"],
            "rest_recoveries": bowel.recovery_count(data) - swept["recoveries"],
            "asleep_each_second": asleep}


def fall_path(config: dict[str, str], seconds: float = 0.5, every: float = 0.01) -> np.ndarray:
    """The paper's fall with the intestine's `config`: its axis (400 points) every `every` s."""
    xml = scene.with_intestine_config(scene.scene_file(SCENE_FILES["fall"]).read_text(), config)
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    gut = viscera.intestines(model)[0]
    stride = int(round(every / model.opt.timestep))
    path = []
    for step in range(int(round(seconds / model.opt.timestep))):
        mujoco.mj_step(model, data)
        if (step + 1) % stride == 0:
            path.append(gut.axis_points(data, 400).copy())
    return np.array(path)


def fall_accuracy() -> dict:
    """The fall at the plugin's substeps against 8 substeps a step (m)."""
    reference, ours = fall_path({"substeps": "8"}), fall_path({})
    centroid = np.linalg.norm(ours.mean(axis=1) - reference.mean(axis=1), axis=1)
    mean_distance = np.linalg.norm(ours - reference, axis=2).mean(axis=1)
    return {"reference_substeps": 8, "largest_centroid_distance_m": float(centroid.max()),
            "largest_mean_point_distance_m": float(mean_distance.max())}


def run(sweeps: list[float], rest_s: float, quiet: bool = False) -> dict:
    runs = [sweep_then_rest(s, rest_s) for s in tqdm(sweeps, desc="sweeps", disable=quiet)]
    final = [r["asleep_each_second"][-1] for r in runs]
    return {"viscera": getattr(viscera, "__version__", "?"), "substeps": substeps(), "rest_s": rest_s,
            "sweeps": runs, "median_asleep_after_rest": statistics.median(final),
            "least_asleep_after_rest": min(final),
            "recoveries": sum(r["sweep_recoveries"] + r["rest_recoveries"] for r in runs),
            "fall": fall_accuracy()}


def report(results: dict) -> str:
    lines = []
    for name, s in results["substeps"].items():
        steps = ", ".join(f"{i['substeps']} (elastic {i['elastic_rad_s']:.0f} rad/s, contact "
                          f"{i['contact_rad_s']:.0f} rad/s)" for i in s["intestines"])
        lines.append(f"{name} ({1e3 * s['timestep_s']:g} ms step): substeps {steps}")
    for r in results["sweeps"]:
        lines.append(f"sweep {r['sweep_s']:g} s: {r['sweep_recoveries']} recoveries, {r['sweep_failures']} failures, "
                     f"{r['sweep_wall_s_per_sim_s']:.3f} wall s / sim s; asleep each second of rest: "
                     + " ".join(f"{a:.2f}" for a in r["asleep_each_second"]))
    lines.append(f"asleep after {results['rest_s']:g} s of rest: median {results['median_asleep_after_rest']:.2f}, "
                 f"least {results['least_asleep_after_rest']:.2f}; recoveries in all: {results['recoveries']}")
    f = results["fall"]
    lines.append(f"fall against {f['reference_substeps']} substeps: centroid within "
                 f"{1e3 * f['largest_centroid_distance_m']:.2f} mm, mean point distance at most "
                 f"{1e3 * f['largest_mean_point_distance_m']:.2f} mm")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sweeps", nargs="+", type=cli.duration, default=[4.0, 8.0, 12.0, 16.0, 20.0],
                        help="sweep lengths, each a run from the start (s)")
    parser.add_argument("--rest", type=cli.duration, default=5.0, help="rest after each sweep (s)")
    parser.add_argument("--json", type=cli.output_file(".json"), help="also write the figures to this JSON file")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    args = parser.parse_args(argv)
    results = run(args.sweeps, args.rest, args.quiet)
    print(report(results))
    if args.json:
        pathlib.Path(args.json).write_text(json.dumps(results, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
