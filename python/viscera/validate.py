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


def _stable(config: dict, step: float, seconds: float = 0.2) -> str:
    """'stable', or how a released, 2 %-stretched straight rod fails at this RK4 substep (s):
    'diverged' (the guard caught NaN or runaway speed) or 'stretch runaway' (length off by 50 %)."""
    xml = (f'<mujoco><option timestep="{step}" gravity="0 0 0"/>'
           f'{viscera.extension_xml("rod", **config, substeps=1)}<worldbody/></mujoco>')
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    gut = viscera.intestine(model)
    gut.positions(data)[:] *= 1.02
    for _ in range(int(np.ceil(seconds / step))):
        mujoco.mj_step(model, data)
        if gut.divergence_count(data):
            return "diverged"
    if abs(gut.length(data, 2000) / config["length"] - 1.0) > 0.5:
        return "stretch runaway"
    return "stable"


def largest_stable_step(config: dict) -> tuple[float, str]:
    """Bisection (in log) of the largest stable RK4 substep (s), and how the next step up fails."""
    low, high = 1e-6, 2e-2
    failure = _stable(config, high)
    if failure == "stable":
        return high, "stable at 20 ms"
    for _ in range(14):
        middle = np.sqrt(low * high)
        outcome = _stable(config, middle)
        if outcome == "stable":
            low = middle
        else:
            high, failure = middle, outcome
    return low, failure


def stability_map(quick: bool = False) -> dict:
    """Largest stable RK4 substep against stretch stiffness (250 points) and against control points
    (default stiffness), 4 m rod, no damping, no contact. The plugin's divergence warnings, expected
    past each limit, are silenced meanwhile."""
    mujoco.set_mju_user_warning(lambda message: None)
    try:
        return _stability_map(quick)
    finally:
        mujoco.set_mju_user_warning(None)


def _stability_map(quick: bool) -> dict:
    base = dict(length=4, damping=0, self_collision=0, shape="line")
    stiffnesses = (10, 100, 1000) if quick else (3, 10, 30, 100, 300, 1000)
    counts = (50, 250) if quick else (25, 50, 100, 250, 500, 1000)
    out = {"integrator": "rk4", "against_stretch_stiffness": [], "against_control_points": []}
    for k in tqdm(stiffnesses, desc="stability vs stiffness", leave=False):
        step, failure = largest_stable_step(dict(base, control_points=250, stretch_stiffness=k))
        out["against_stretch_stiffness"].append({"stretch_stiffness": k, "largest_step_s": step, "failure": failure})
    for n in tqdm(counts, desc="stability vs points", leave=False):
        step, failure = largest_stable_step(dict(base, control_points=n))
        out["against_control_points"].append({"control_points": n, "largest_step_s": step, "failure": failure})
    return out


def cost_per_step(quick: bool = False) -> dict:
    """Wall time of one RK4 substep (s) against control points, 4 m rod dropped onto a plane with
    self-collision (the default 321 spheres), over its first 0.1 s; and the log-log slope."""
    counts = (25, 100, 400) if quick else (25, 50, 100, 250, 500, 1000, 2000)
    rows = []
    for n in tqdm(counts, desc="cost per step", leave=False):
        step = min(1e-3, 0.25 / n)  # under the stability limit at every n
        xml = (f'<mujoco><option timestep="{step}"/>'
               f'{viscera.extension_xml("rod", length=4, control_points=n, substeps=1, shape="line", start=[0, 0, 0.05], direction=[1, 0, 0.05])}'
               f'<worldbody><geom type="plane" size="5 5 0.1"/></worldbody></mujoco>')
        model = mujoco.MjModel.from_xml_string(xml)
        data = mujoco.MjData(model)
        steps = int(np.ceil(0.1 / step))
        start = time.perf_counter()
        for _ in range(steps):
            mujoco.mj_step(model, data)
        rows.append({"control_points": n, "seconds_per_substep": (time.perf_counter() - start) / steps})
    n = np.log([r["control_points"] for r in rows])
    t = np.log([r["seconds_per_substep"] for r in rows])
    return {"rows": rows, "slope": float(np.polyfit(n, t, 1)[0])}


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


def plot_maps(stability: dict, cost: dict, folder: pathlib.Path) -> list[pathlib.Path]:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 2, figsize=(9, 3.6))
    for ax, key, label in ((axes[0], "against_stretch_stiffness", "stretch_stiffness"),
                           (axes[1], "against_control_points", "control_points")):
        rows = stability[key]
        x = [r[label] for r in rows]
        y = [r["largest_step_s"] * 1e3 for r in rows]
        ax.loglog(x, y, "o-", label="RK4: largest stable substep")
        for r in rows:
            ax.annotate(r["failure"], (r[label], r["largest_step_s"] * 1e3 * 1.1), fontsize=7)
        ax.set_xlabel(label.replace("_", " ") + (" (N/m)" if "stiffness" in label else ""))
        ax.set_ylabel("substep (ms)")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle("stability map (4 m rod, released from 2 % stretch, no damping); label: failure past it", fontsize=9)
    fig.tight_layout()
    stability_path = folder / "stability_map.png"
    fig.savefig(stability_path, dpi=110)
    plt.close(fig)
    fig, ax = plt.subplots(figsize=(5, 3.6))
    x = [r["control_points"] for r in cost["rows"]]
    y = [r["seconds_per_substep"] * 1e6 for r in cost["rows"]]
    ax.loglog(x, y, "o-", label=f"RK4 substep, self-collision on (slope {cost['slope']:.2f})")
    ax.set_xlabel("control points")
    ax.set_ylabel("wall time per substep (us)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    cost_path = folder / "cost_per_step.png"
    fig.savefig(cost_path, dpi=110)
    plt.close(fig)
    return [stability_path, cost_path]


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
    stability = stability_map(args.quick)
    cost = cost_per_step(args.quick)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "results.json").write_text(json.dumps(
        {"cases": results, "stability_map": stability, "cost_per_step": cost}, indent=2))
    plot(results, args.out)
    plot_maps(stability, cost, args.out)
    print(report(results))
    for key, label in (("against_stretch_stiffness", "stretch_stiffness"), ("against_control_points", "control_points")):
        print("RK4 largest stable substep vs " + label + ": " + ", ".join(
            f"{r[label]}: {r['largest_step_s'] * 1e3:.3g} ms ({r['failure']})" for r in stability[key]))
    print("cost per substep (us): " + ", ".join(f"n={r['control_points']}: {r['seconds_per_substep'] * 1e6:.1f}"
                                                 for r in cost["rows"]) + f"; log-log slope {cost['slope']:.2f}")
    print(f"wrote {args.out / 'results.json'} and the charts")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
