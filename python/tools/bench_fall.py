"""Benchmarks, ours against MuJoCo's 1D flexcomp in the same process.

    python python/tools/bench_fall.py [--duration 5] [--runs 3] [--json out.json] [--plot scaling.png]

1. The paper's fall: the same 4 m, 12.5 mm-radius, 1000 kg/m^3 tube of 250
   points, tilted by 0.1 rad, dropped from 0.1 m onto a plane, one thread each,
   each at its own usable step: ours at its defaults (2 ms MuJoCo step, the
   substeps chosen from it: 3 leapfrog substeps with self-collision, 2
   without) with self-collision on and off; the flexcomp (edge equality
   constraints, implicitfast) at 1 ms, under its measured 1.2 ms stability
   limit, with selfcollide none and auto. Wall seconds per simulated second,
   medians over runs.
2. The collision pass (paper 3.3.1) against the number of spheres, 250 to
   8000 piled at constant density: the slope of log time against log n (1 is
   linear).
3. What each scale costs: the same fall for intestines of 2, 4, 8 and 16 m at
   the default resolution (62.5 control points and 80 collision spheres per m).
"""

from __future__ import annotations

import argparse
import json
import pathlib
import statistics
import subprocess
import tempfile
import time

import mujoco
import numpy as np
from tqdm import tqdm

import viscera
from viscera import cli

LENGTH = 4.0
RADIUS = 0.0125
POINTS = 250
MASS = 1000.0 * np.pi * RADIUS**2 * LENGTH
TILT = 0.1  # rad
START = (0.0, 0.0, 0.1)
FLOOR = '<geom name="floor" type="plane" size="5 5 0.1"/>'


def _direction() -> np.ndarray:
    return np.array([np.cos(TILT), 0.0, np.sin(TILT)])


def viscera_xml(self_collision: int = 1, length: float = LENGTH, points: int = POINTS) -> str:
    extension = viscera.extension_xml("intestine", length=length, control_points=points, radius=RADIUS,
                                      shape="line", start=START, direction=_direction(), self_collision=self_collision)
    return f'<mujoco><option timestep="0.002"/>{extension}<worldbody>{FLOOR}</worldbody></mujoco>'


def flexcomp_xml(selfcollide: str = "none") -> str:
    points = np.asarray(START) + np.outer(np.linspace(0.0, LENGTH, POINTS), _direction())
    point = " ".join(f"{x:.9g}" for x in points.ravel())
    element = " ".join(f"{i} {i + 1}" for i in range(POINTS - 1))
    return (f'<mujoco><option timestep="0.001" integrator="implicitfast"/><worldbody>{FLOOR}'
            f'<flexcomp name="rod" type="direct" dim="1" radius="{RADIUS}" mass="{MASS}" point="{point}" '
            f'element="{element}"><edge equality="true"/><contact selfcollide="{selfcollide}"/></flexcomp>'
            '</worldbody></mujoco>')


def _viscera_axis(model, data) -> np.ndarray:
    return viscera.intestine(model).axis_points(data, 4000)


def _flexcomp_axis(model, data) -> np.ndarray:
    return data.flexvert_xpos.reshape(-1, 3).copy()


PEERS = {
    "viscera": (viscera_xml, _viscera_axis),
    "viscera_noself": (lambda: viscera_xml(self_collision=0), _viscera_axis),
    "flexcomp": (flexcomp_xml, _flexcomp_axis),
    "flexcomp_self": (lambda: flexcomp_xml("auto"), _flexcomp_axis),
}
LABELS = {"viscera": "viscera, self-collision on", "viscera_noself": "viscera, self-collision off",
          "flexcomp": "flexcomp, selfcollide none", "flexcomp_self": "flexcomp, selfcollide auto"}
SCALING_SIZES = (250, 500, 1000, 2000, 4000, 8000)


def piled_chain(count: int, radius: float = RADIUS, seed: int = 0) -> np.ndarray:
    """Sphere centres (one radius apart) of a tube piled at a 30 % volume fraction:
    a persistent random walk (it turns by about 0.3 rad per sphere, so it is smooth
    over some 10 radii, like a bowel, not crumpled at the sphere scale) folded by
    reflection into the cube that holds it at that density."""
    rng = np.random.default_rng(seed)
    side = (count * np.pi * radius**3 / 0.3) ** (1.0 / 3.0)
    direction = np.array([1.0, 0.0, 0.0])
    steps = np.empty((count, 3))
    for k in range(count):
        direction = direction + 0.3 * rng.normal(size=3)
        direction /= np.linalg.norm(direction)
        steps[k] = radius * direction
    walk = np.cumsum(steps, axis=0)
    folded = np.abs((walk % (2 * side)) - side)  # reflect into [0, side]
    return np.ascontiguousarray(folded)


ROOT = pathlib.Path(__file__).resolve().parents[2]


def collision_pass_program(build: pathlib.Path | None = None) -> pathlib.Path:
    """The C benchmark of the collision pass (tests/c/bench_collision_pass.c), built from this
    checkout's core (no MuJoCo) into `build` (default build/bench-c) with cmake."""
    build = build or ROOT / "build" / "bench-c"
    for command in (["cmake", "-S", str(ROOT), "-B", str(build), "-DVISCERA_BUILD_PLUGIN=OFF",
                     "-DCMAKE_BUILD_TYPE=Release"],
                    ["cmake", "--build", str(build), "--target", "bench_collision_pass", "--parallel", "2"]):
        result = subprocess.run(command, capture_output=True, text=True)
        if result.returncode:
            raise RuntimeError(f"{' '.join(command)} failed:\n{result.stdout[-2000:]}{result.stderr[-2000:]}")
    return build / "bench_collision_pass"


def collision_pass_scaling(sizes=SCALING_SIZES, repeats: int = 20, build: pathlib.Path | None = None) -> dict:
    """Fastest collision pass time for each sphere count (timed in C), and the log-log slope."""
    program = collision_pass_program(build)
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        for count in sizes:
            path = pathlib.Path(folder) / f"pile_{count}.bin"
            piled_chain(count).astype("<f8").tofile(path)
            output = subprocess.run([str(program), str(path), repr(RADIUS), str(repeats)], capture_output=True,
                                    text=True, check=True).stdout.split()
            rows.append({"spheres": count, "seconds": float(output[0]), "contacts": int(output[1])})
    n = np.array([r["spheres"] for r in rows], dtype=float)
    t = np.array([r["seconds"] for r in rows])
    slope = float(np.polyfit(np.log(n), np.log(t), 1)[0])
    large = n >= 1000  # past the size where the grid's working set leaves the L1 cache
    slope_large = float(np.polyfit(np.log(n[large]), np.log(t[large]), 1)[0]) if large.sum() >= 2 else slope
    return {"rows": rows, "slope": slope, "slope_from_1000": slope_large}


SCALES_M = (2.0, 4.0, 8.0, 16.0)


def scale_costs(duration: float, runs: int) -> list[dict]:
    """Wall seconds per simulated second of the fall against the intestine's length."""
    rows = []
    for length in SCALES_M:
        points = int(round(POINTS * length / LENGTH))
        walls = []
        for _ in range(runs):
            model = mujoco.MjModel.from_xml_string(viscera_xml(length=length, points=points))
            walls.append(_time_model(model, duration)[0])
        rows.append({"length_m": length, "control_points": points,
                     "collision_spheres": viscera.intestine(model).sphere_count,
                     "wall_s_per_sim_s_median": statistics.median(walls)})
    return rows


def _time_model(model: mujoco.MjModel, duration: float):
    data = mujoco.MjData(model)
    steps = int(round(duration / model.opt.timestep))
    start = time.perf_counter()
    for _ in range(steps):
        mujoco.mj_step(model, data)
    return (time.perf_counter() - start) / data.time, data


def time_one(name: str, duration: float) -> dict:
    """Simulate one peer for `duration` s; wall time of stepping only."""
    make_xml, axis = PEERS[name]
    model = mujoco.MjModel.from_xml_string(make_xml())
    wall_per_sim, data = _time_model(model, duration)
    points = axis(model, data)
    length = float(np.linalg.norm(np.diff(points, axis=0), axis=1).sum())
    return {"wall_per_sim": wall_per_sim, "length_error": length / LENGTH - 1.0,
            "lowest_z": float(points[:, 2].min()), "timestep": model.opt.timestep}


def run(duration: float = 5.0, runs: int = 3, quiet: bool = False) -> dict:
    """Alternate the peers `runs` times (so machine noise hits both) and take medians."""
    samples: dict[str, list[dict]] = {name: [] for name in PEERS}
    with tqdm(total=runs * len(PEERS), unit="run", disable=quiet, desc="benchmark") as bar:
        for _ in range(runs):
            for name in PEERS:
                samples[name].append(time_one(name, duration))
                bar.update(1)
    result: dict = {"duration_s": duration, "runs": runs, "control_points": POINTS, "peers": {}}
    for name, rows in samples.items():
        walls = [r["wall_per_sim"] for r in rows]
        result["peers"][name] = {
            "wall_s_per_sim_s_median": statistics.median(walls), "wall_s_per_sim_s_runs": walls,
            "length_error": rows[-1]["length_error"], "lowest_z_m": rows[-1]["lowest_z"],
            "timestep_s": rows[-1]["timestep"]}
    ours = result["peers"]["viscera"]["wall_s_per_sim_s_median"]
    result["speedup_vs_flexcomp_selfcollide"] = result["peers"]["flexcomp_self"]["wall_s_per_sim_s_median"] / ours
    result["speedup_vs_flexcomp"] = result["peers"]["flexcomp"]["wall_s_per_sim_s_median"] / ours
    result["collision_pass"] = collision_pass_scaling()
    result["scales"] = scale_costs(min(duration, 2.0), runs)
    result["skin"] = skin_cost()
    return result


def skin_cost(repeats: int = 50) -> dict:
    """Median time to skin the settled 250-point intestine at the default resolution."""
    model = mujoco.MjModel.from_xml_string(viscera_xml())
    _, data = _time_model(model, 0.5)
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        vertices, _, triangles = viscera.skin(model, data)
        times.append(time.perf_counter() - start)
    return {"seconds_median": statistics.median(times), "vertices": len(vertices), "triangles": len(triangles)}


def plot_scaling(scaling: dict, path: str) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    n = np.array([r["spheres"] for r in scaling["rows"]], dtype=float)
    t = np.array([r["seconds"] for r in scaling["rows"]]) * 1e6
    fig, ax = plt.subplots(figsize=(5, 3.5))
    ax.loglog(n, t, "o-", label=f"collision pass (slope {scaling['slope']:.2f}, {scaling['slope_from_1000']:.2f} from 1000)")
    ax.loglog(n, t[0] * n / n[0], "--", color="gray", label="linear")
    ax.set_xlabel("collision spheres, piled")
    ax.set_ylabel("one pass (us)")
    ax.legend()
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python python/tools/bench_fall.py", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--duration", type=cli.duration, default=5.0,
                        help="simulated seconds per run (default 5)")
    parser.add_argument("--runs", type=cli.positive_int, default=3, help="runs per peer, median reported (default 3)")
    parser.add_argument("--json", type=cli.output_file(".json"), help="also write the figures to this JSON file")
    parser.add_argument("--plot", type=cli.output_file(".png"), help="also draw the collision-pass scaling to this PNG")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    args = parser.parse_args(argv)
    if args.duration < 0.01:
        parser.error(f"argument --duration: must be at least 0.01 s (several steps), got {args.duration:g}")
    result = run(args.duration, args.runs, args.quiet)
    print(f"{POINTS}-point, {LENGTH:g} m fall onto a plane, {args.duration:g} s simulated, median of {args.runs} runs")
    for name, peer in result["peers"].items():
        print(f"  {LABELS[name]:29s} dt {peer['timestep_s'] * 1e3:.1f} ms: {peer['wall_s_per_sim_s_median']:.4f} "
              f"wall s / sim s, length error {peer['length_error'] * 100:+.2f} %, "
              f"lowest axis point {peer['lowest_z_m'] * 1e3:.1f} mm")
    print(f"  viscera (self-collision on) is {result['speedup_vs_flexcomp_selfcollide']:.1f}x faster than the flexcomp "
          f"with selfcollide, {result['speedup_vs_flexcomp']:.2f}x faster than it without")
    scaling = result["collision_pass"]
    print("collision pass, piled chain at constant density (fastest of 20):")
    for row in scaling["rows"]:
        print(f"  {row['spheres']:5d} spheres: {row['seconds'] * 1e6:8.1f} us "
              f"({row['seconds'] * 1e9 / row['spheres']:.0f} ns per sphere), {row['contacts']} overlapping pairs")
    print(f"  slope of log time vs log spheres: {scaling['slope']:.2f} over all sizes, "
          f"{scaling['slope_from_1000']:.2f} from 1000 spheres (1 = linear)")
    print(f"what each scale costs (the same fall, {min(args.duration, 2.0):g} s, median of {args.runs}):")
    for row in result["scales"]:
        print(f"  {row['length_m']:4.0f} m, {row['control_points']:4d} control points, {row['collision_spheres']:4d} spheres: "
              f"{row['wall_s_per_sim_s_median']:.3f} wall s / sim s")
    skin = result["skin"]
    print(f"skin of the 250-point intestine ({skin['vertices']} vertices, {skin['triangles']} triangles): "
          f"{skin['seconds_median'] * 1e3:.3f} ms (median of 50, from Python)")
    if args.plot:
        plot_scaling(scaling, args.plot)
        print(f"  figure: {args.plot}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(result, f, indent=2)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
