"""Benchmark: the paper's 250-point fall, ours against MuJoCo's 1D flexcomp, same process.

    python -m viscera.bench [--duration 5] [--runs 3] [--json out.json]

Both drop the same 4 m, 12.5 mm-radius, 1000 kg/m^3 tube, tilted by 0.1 rad,
from 0.1 m onto a plane, one thread each, each at its own usable step: ours at
its defaults (2 ms MuJoCo step, 2 RK4 substeps), the flexcomp (edge equality
constraints, implicitfast) at 1 ms, under its measured 1.2 ms stability limit.
Figures are wall seconds per simulated second, medians over runs.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time

import mujoco
import numpy as np
from tqdm import tqdm

import viscera

LENGTH = 4.0
RADIUS = 0.0125
POINTS = 250
MASS = 1000.0 * np.pi * RADIUS**2 * LENGTH
TILT = 0.1  # rad
START = (0.0, 0.0, 0.1)
FLOOR = '<geom name="floor" type="plane" size="5 5 0.1"/>'


def _direction() -> np.ndarray:
    return np.array([np.cos(TILT), 0.0, np.sin(TILT)])


def viscera_xml() -> str:
    extension = viscera.extension_xml("intestine", length=LENGTH, control_points=POINTS, radius=RADIUS,
                                      shape="line", start=START, direction=_direction())
    return f'<mujoco><option timestep="0.002"/>{extension}<worldbody>{FLOOR}</worldbody></mujoco>'


def flexcomp_xml() -> str:
    points = np.asarray(START) + np.outer(np.linspace(0.0, LENGTH, POINTS), _direction())
    point = " ".join(f"{x:.9g}" for x in points.ravel())
    element = " ".join(f"{i} {i + 1}" for i in range(POINTS - 1))
    return (f'<mujoco><option timestep="0.001" integrator="implicitfast"/><worldbody>{FLOOR}'
            f'<flexcomp name="rod" type="direct" dim="1" radius="{RADIUS}" mass="{MASS}" point="{point}" '
            f'element="{element}"><edge equality="true"/><contact selfcollide="none"/></flexcomp>'
            '</worldbody></mujoco>')


def _viscera_axis(model, data) -> np.ndarray:
    return viscera.intestine(model).axis_points(data, 4000)


def _flexcomp_axis(model, data) -> np.ndarray:
    return data.flexvert_xpos.reshape(-1, 3).copy()


PEERS = {
    "viscera": (viscera_xml, _viscera_axis),
    "flexcomp": (flexcomp_xml, _flexcomp_axis),
}


def time_one(name: str, duration: float) -> dict:
    """Simulate one peer for `duration` s; wall time of stepping only."""
    make_xml, axis = PEERS[name]
    model = mujoco.MjModel.from_xml_string(make_xml())
    data = mujoco.MjData(model)
    steps = int(round(duration / model.opt.timestep))
    start = time.perf_counter()
    for _ in range(steps):
        mujoco.mj_step(model, data)
    wall = time.perf_counter() - start
    points = axis(model, data)
    length = float(np.linalg.norm(np.diff(points, axis=0), axis=1).sum())
    return {"wall_per_sim": wall / data.time, "length_error": length / LENGTH - 1.0,
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
    result["speedup_vs_flexcomp"] = result["peers"]["flexcomp"]["wall_s_per_sim_s_median"] / ours
    return result


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m viscera.bench", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--duration", type=float, default=5.0, help="simulated seconds per run (default 5)")
    parser.add_argument("--runs", type=int, default=3, help="runs per peer, median reported (default 3)")
    parser.add_argument("--json", help="also write the figures to this JSON file")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    args = parser.parse_args(argv)
    if args.runs < 1 or args.duration <= 0:
        parser.error("--runs must be >= 1 and --duration positive")
    result = run(args.duration, args.runs, args.quiet)
    print(f"{POINTS}-point, {LENGTH:g} m fall onto a plane, {args.duration:g} s simulated, median of {args.runs} runs")
    for name, peer in result["peers"].items():
        print(f"  {name:9s} dt {peer['timestep_s'] * 1e3:.1f} ms: {peer['wall_s_per_sim_s_median']:.4f} wall s / sim s, "
              f"length error {peer['length_error'] * 100:+.2f} %, lowest axis point {peer['lowest_z_m'] * 1e3:.1f} mm")
    print(f"  viscera is {result['speedup_vs_flexcomp']:.2f}x faster than the flexcomp")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(result, f, indent=2)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
