"""Validation cases against analytic references, at several resolutions, with charts.

    python -m viscera.validate [--quick] [--out docs/validation]

Each case builds a MuJoCo model with one intestine (the whole stack: plugin,
core, MuJoCo's step), lets it come to rest under damping (dynamic
relaxation), and compares a measured value with its analytic reference
(formulas in ../shared/NOTES.md):

- catenary: 4 m, ends pinned 3 m apart, the paper's springs with a stiff
  global length term: sag a (cosh(D / 2a) - 1) = 1.177335 m;
- hanging rod: 1 m of a solid tube of E = 1e5 Pa hanging from its top:
  stretch mu g L^2 / (2 EA) (the springs carry EA = E pi r^2);
- cantilever: 0.5 m clamped (first two control points pinned) under its own
  weight, EI from young_modulus: tip deflection w L^4 / (8 EI), small (1 % of L).

Per case and resolution: the value, the reference, the relative error, the
wall seconds per simulated second, and the error's order of convergence in
control points. Writes results.json and one chart per case (error against
wall time, the Pareto view) into the output folder.
"""

from __future__ import annotations

import argparse
import json
import pathlib
import time

import viscera  # first: headless GL backend

import mujoco  # noqa: E402
import numpy as np  # noqa: E402
from tqdm import tqdm  # noqa: E402

G = 9.81
RADIUS = 0.0125
DENSITY = 1000.0
MU = DENSITY * np.pi * RADIUS**2  # kg/m


def _relax(config: dict, duration: float, timestep: float, gravity=(0.0, 0.0, -G)):
    """Compile and step an intestine for `duration` s; return its data, intestine, wall s per sim s."""
    xml = (f'<mujoco><option timestep="{timestep}" gravity="{gravity[0]} {gravity[1]} {gravity[2]}"/>'
           f'{viscera.extension_xml("rod", **config)}<worldbody/></mujoco>')
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    gut = viscera.intestine(model)
    steps = int(round(duration / timestep))
    start = time.perf_counter()
    for _ in range(steps):
        mujoco.mj_step(model, data)
    wall = time.perf_counter() - start
    if gut.divergence_count(data):
        raise RuntimeError(f"diverged: {config}")
    return data, gut, wall / (steps * timestep)


def catenary(n: int) -> dict:
    depth = np.sqrt(2.0**2 - 1.5**2)  # a V of the rod's length
    config = dict(length=4, control_points=n, stretch_stiffness=100, bend_stiffness=0, global_stretch_stiffness=5000,
                  damping=4, substeps=2, self_collision=0, shape="polyline",
                  points=[-1.5, 0, 0, 0, 0, -depth, 1.5, 0, 0], pinned=[0, n - 1])
    data, gut, cost = _relax(config, 6.0, 0.001)
    sag = -gut.axis_points(data, 20001)[:, 2].min()
    return {"value": sag, "reference": 1.177335, "unit": "m", "wall_s_per_sim_s": cost}


def hanging_rod(n: int) -> dict:
    young, length = 1.0e5, 1.0
    area = np.pi * RADIUS**2
    config = dict(length=length, control_points=n, radius=RADIUS, density=DENSITY, young_modulus=young, damping=6,
                  substeps=2, self_collision=0, shape="line", direction=[0, 0, -1], pinned=[0])
    data, gut, cost = _relax(config, 5.0, 0.001)
    reference = MU * G * length**2 / (2.0 * young * area)
    return {"value": gut.length(data) - length, "reference": reference, "unit": "m", "wall_s_per_sim_s": cost}


def cantilever(n: int) -> dict:
    length, tip_fraction = 0.5, 0.01
    second_moment = np.pi * RADIUS**4 / 4.0
    rigidity = MU * G * length**4 / (8.0 * tip_fraction * length)   # EI for a 1 % tip deflection
    young = rigidity / second_moment
    # the axis barely stretches here: a softer EA (raw stiffness wins) keeps the step affordable
    spacing = length / (2 * (n - 1))  # sample spacing (m)
    omega = np.sqrt(rigidity / spacing**3 / (MU * spacing)) * 2.0  # stiffest curvature mode (rad/s)
    substeps = int(np.ceil(1e-3 * omega / 1.5))
    config = dict(length=length, control_points=n, radius=RADIUS, density=DENSITY, young_modulus=young,
                  stretch_stiffness=2000, damping=30, substeps=substeps, self_collision=0, shape="line",
                  direction=[1, 0, 0], pinned=[0, 1])
    data, gut, cost = _relax(config, 0.6, 0.001)
    tip = gut.axis_points(data, 2)[-1]
    return {"value": -tip[2], "reference": MU * G * length**4 / (8.0 * rigidity), "unit": "m",
            "wall_s_per_sim_s": cost, "substeps": substeps}


CASES = {"catenary": (catenary, (25, 50, 100, 200)),
         "hanging_rod": (hanging_rod, (10, 20, 40, 80)),
         "cantilever": (cantilever, (8, 16, 32, 48))}


def run(quick: bool = False, quiet: bool = False) -> dict:
    jobs = [(name, n) for name, (_, sizes) in CASES.items() for n in (sizes[:2] if quick else sizes)]
    results: dict = {name: [] for name in CASES}
    for name, n in tqdm(jobs, desc="validation", disable=quiet):
        row = CASES[name][0](n)
        row["control_points"] = n
        row["relative_error"] = abs(row["value"] - row["reference"]) / abs(row["reference"])
        results[name].append(row)
    for name, rows in results.items():
        if len(rows) >= 2:  # observed order: slope of log error against log n, last two resolutions
            a, b = rows[-2], rows[-1]
            if a["relative_error"] > 0 and b["relative_error"] > 0:
                rows[-1]["order_in_control_points"] = float(
                    -np.log(b["relative_error"] / a["relative_error"]) / np.log(b["control_points"] / a["control_points"]))
    return results


def plot(results: dict, folder: pathlib.Path) -> list[pathlib.Path]:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    paths = []
    for name, rows in results.items():
        fig, ax = plt.subplots(figsize=(5, 3.6))
        x = [r["wall_s_per_sim_s"] for r in rows]
        y = [max(r["relative_error"], 1e-12) for r in rows]
        ax.loglog(x, y, "o-", label="viscera (RK4)")
        for r in rows:
            ax.annotate(f"n={r['control_points']}", (r["wall_s_per_sim_s"], max(r["relative_error"], 1e-12)),
                        textcoords="offset points", xytext=(4, 4), fontsize=8)
        ax.set_xlabel("wall seconds per simulated second")
        ax.set_ylabel("relative error")
        ax.set_title(name.replace("_", " "))
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
        fig.tight_layout()
        path = folder / f"pareto_{name}.png"
        fig.savefig(path, dpi=110)
        plt.close(fig)
        paths.append(path)
    return paths


def report(results: dict) -> str:
    lines = [f"{'case':<13}{'n':>5}{'value':>13}{'reference':>13}{'rel. error':>12}{'wall s/sim s':>14}{'order':>7}"]
    for name, rows in results.items():
        for r in rows:
            order = f"{r['order_in_control_points']:.2f}" if "order_in_control_points" in r else ""
            lines.append(f"{name:<13}{r['control_points']:>5}{r['value']:>13.6g}{r['reference']:>13.6g}"
                         f"{r['relative_error']:>12.2e}{r['wall_s_per_sim_s']:>14.4f}{order:>7}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m viscera.validate", description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="two resolutions per case")
    parser.add_argument("--out", type=pathlib.Path, default=pathlib.Path("docs") / "validation")
    parser.add_argument("--quiet", action="store_true")
    args = parser.parse_args(argv)
    results = run(args.quick, args.quiet)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "results.json").write_text(json.dumps(results, indent=2))
    plot(results, args.out)
    print(report(results))
    print(f"wrote {args.out / 'results.json'} and the charts")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
