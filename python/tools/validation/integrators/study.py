"""The integrators side by side (rk4, leapfrog, symplectic_euler, implicit): the stability map
(largest stable substep against stiffness and resolution), the cost per substep, the speed against
accuracy on a released beam, the stiff catenary and cantilever at a 2 ms step with each at the
fewest substeps that hold, and the energy of an undamped swinging rod over 100 s; and their charts
(stability_map.png, cost_per_step.png, integrators.png).
"""

from __future__ import annotations

import functools
import pathlib
import time

import viscera  # first: headless GL backend

import mujoco  # noqa: E402
import numpy as np  # noqa: E402
from tqdm import tqdm  # noqa: E402

from validation.cantilever.case import cantilever  # noqa: E402
from validation.catenary.case import catenary  # noqa: E402
from validation.common import G, compile_rod, quiet_warnings  # noqa: E402


def stable_outcome(config: dict, step: float, seconds: float = 0.2, integrator: str = "rk4") -> str:
    """'stable', or how a released, 2 %-stretched straight rod fails at this substep (s) of
    `integrator`, with no retries: 'diverged' (the guard caught NaN, runaway speed or an energy
    jump) or 'stretch runaway' (length off by 50 %)."""
    xml = (f'<mujoco><option timestep="{step}" gravity="0 0 0"/>'
           f'{viscera.extension_xml("rod", **config, substeps=1, integrator=integrator, divergence_retries=0)}'
           '<worldbody/></mujoco>')
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


def largest_stable_step(config: dict, integrator: str = "rk4") -> tuple[float, str]:
    """Bisection (in log) of the largest stable substep (s) of `integrator`, and how the next
    step up fails."""
    low, high = 1e-6, 2e-2
    failure = stable_outcome(config, high, integrator=integrator)
    if failure == "stable":
        return high, "stable at 20 ms"
    for _ in range(14):
        middle = np.sqrt(low * high)
        outcome = stable_outcome(config, middle, integrator=integrator)
        if outcome == "stable":
            low = middle
        else:
            high, failure = middle, outcome
    return low, failure


INTEGRATORS = viscera.allowed_values("integrator")  # the plugin's list


def stability_map(quick: bool = False) -> dict:
    """Largest stable substep of each integrator against stretch stiffness (250 points) and
    against control points (default stiffness), 4 m rod, no damping, no contact, no retries."""
    with quiet_warnings():
        return {name: _stability_map(quick, name) for name in INTEGRATORS}


def _stability_map(quick: bool, integrator: str) -> dict:
    base = dict(length=4, damping=0, self_collision=0, shape="line")
    stiffnesses = (10, 100, 1000) if quick else (3, 10, 30, 100, 300, 1000)
    counts = (50, 250) if quick else (25, 50, 100, 250, 500, 1000)
    out = {"against_stretch_stiffness": [], "against_control_points": []}
    for k in tqdm(stiffnesses, desc=f"{integrator} stability vs stiffness", leave=False):
        step, failure = largest_stable_step(dict(base, control_points=250, stretch_stiffness=k), integrator)
        out["against_stretch_stiffness"].append({"stretch_stiffness": k, "largest_step_s": step, "failure": failure})
    for n in tqdm(counts, desc=f"{integrator} stability vs points", leave=False):
        step, failure = largest_stable_step(dict(base, control_points=n), integrator)
        out["against_control_points"].append({"control_points": n, "largest_step_s": step, "failure": failure})
    return out


def fewestrk4_substeps(case, limit: int = 512) -> tuple[int, dict]:
    """The fewest substeps (powers of two) at which `case(substeps)` runs without diverging, and
    its row; (0, {}) if even `limit` diverges."""
    substeps = 1
    with quiet_warnings():
        while substeps <= limit:
            try:
                return substeps, case(substeps)
            except RuntimeError:
                substeps *= 2
    return 0, {}


def stiff_comparison(quick: bool = False) -> list[dict]:
    """At a 2 ms MuJoCo step, where RK4 needs many substeps: the catenary at 100x its stretch
    stiffness (n = 100) and the clamped cantilever (n = 32; EI for 1 % deflection), each with
    every integrator at the fewest substeps that hold. Rows: case, integrator, substeps, value,
    relative error, wall s per sim s."""
    cases = {"catenary (stretch 10000 N/m, n = 100)": lambda integrator, s: catenary(
                 50 if quick else 100, integrator, 0.002, s, stretch_stiffness=10000.0),
             "cantilever (n = 32)": lambda integrator, s: cantilever(16 if quick else 32, integrator, 0.002, s)}
    rows = []
    for name, case in tqdm(cases.items(), desc="stiff cases", leave=False):
        for integrator in INTEGRATORS:
            substeps, row = fewestrk4_substeps(functools.partial(case, integrator))
            if row:
                row["relative_error"] = abs(row["value"] - row["reference"]) / abs(row["reference"])
            rows.append(dict(row, case=name, integrator=integrator, substeps=substeps, step_s=0.002))
    return rows


def unstretched_half_sine(n: int, amplitude: float) -> np.ndarray:
    """n control points (m) of a 1 m axis bent into z = amplitude sin(pi s) at arc length s."""
    s = np.linspace(0.0, 1.0, 4001)
    slope = amplitude * np.pi * np.cos(np.pi * s)
    dx = np.sqrt(1.0 - slope**2)
    x = np.concatenate(([0.0], np.cumsum(0.5 * (dx[1:] + dx[:-1]) * np.diff(s))))
    at = np.linspace(0.0, 1.0, n)
    return np.stack([np.interp(at, s, x), np.zeros(n), amplitude * np.sin(np.pi * at)], axis=1)


def integrator_accuracy(quick: bool = False) -> dict:
    """Speed against accuracy of each integrator on a dynamic case: a 1 m, 25-point rod (E = 1e5
    Pa) bent without stretch into half a sine wave of 5 cm and released without damping: its
    position error at t = 0.25 s against RK4 at 0.01 ms, and the wall s per sim s, at MuJoCo
    steps from 4 ms down (one substep each, no retries). Unstretched, so that the start rings
    the bending modes, not the axial ones (which backward Euler would damp away: a floor of
    0.3 % of the amplitude from a 0.6 % stretch, at every step tried)."""
    steps = (2e-3, 5e-4) if quick else (4e-3, 2e-3, 1e-3, 5e-4, 2.5e-4, 1.25e-4)

    def run(integrator, step):
        config = dict(length=1.0, control_points=25, young_modulus=1e5, damping=0, substeps=1, self_collision=0,
                      shape="line", direction=[1, 0, 0], integrator=integrator, divergence_retries=0)
        model, data, gut = compile_rod(config, step, gravity=(0, 0, 0))
        gut.positions(data)[:] = unstretched_half_sine(gut.control_count, 0.05)
        count = int(round(0.25 / step))
        start = time.perf_counter()
        for _ in range(count):
            mujoco.mj_step(model, data)
        wall = (time.perf_counter() - start) / (count * step)
        return gut.positions(data).copy(), gut.divergence_count(data) > 0, wall

    with quiet_warnings():
        reference, _, _ = run("rk4", 1e-5)
        out = {}
        for integrator in INTEGRATORS:
            out[integrator] = []
            for step in tqdm(steps, desc=f"{integrator} accuracy", leave=False):
                positions, diverged, wall = run(integrator, step)
                error = float(np.abs(positions - reference).max() / 0.05)
                out[integrator].append({"step_s": step, "diverged": bool(diverged),
                                        "error_over_amplitude": None if diverged else error,
                                        "wall_s_per_sim_s": wall})
    return out


def energy_bounds(duration: float = 100.0, integrators: tuple[str, ...] = INTEGRATORS) -> dict:
    """A 1 m, 40-point rod pinned at its top swings from 20 degrees for `duration` s without
    damping, at 2 ms: the largest energy error over each half, per swing energy, for leapfrog and
    symplectic Euler (4 substeps: 4 force evaluations a step), RK4 at the same cost (1 substep) and
    the implicit step (1 substep)."""
    tilt = 0.35
    out = {}
    for integrator, substeps in (("leapfrog", 4), ("symplectic_euler", 4), ("rk4", 1), ("implicit", 1)):
        if integrator not in integrators:
            continue
        config = dict(length=1.0, control_points=40, damping=0, substeps=substeps, integrator=integrator,
                      self_collision=0, shape="line", direction=[np.sin(tilt), 0, -np.cos(tilt)], pinned=[0])
        model, data, gut = compile_rod(config, 0.002)
        gut.positions(data)[:] *= 1.01  # 1 % stretched: it rings as it swings
        swing = gut.mass * G * 0.5 * (1.0 - np.cos(tilt))
        start = sum(gut.energy(data).values())
        halves = [0.0, 0.0]
        steps = int(round(duration / 0.002))
        for i in tqdm(range(steps), desc=f"{integrator} energy", leave=False):
            mujoco.mj_step(model, data)
            if i % 10 == 9:
                error = abs(sum(gut.energy(data).values()) - start) / swing
                halves[2 * i // steps] = max(halves[2 * i // steps], error)
        out[integrator] = {"substeps": substeps, "first_half": halves[0], "second_half": halves[1],
                           "final_relative_change": (sum(gut.energy(data).values()) - start) / swing}
    return out


def cost_per_step(quick: bool = False) -> dict:
    """Wall time of one substep (s) of each integrator against control points, 4 m rod dropped
    onto a plane with self-collision (the default 321 spheres), over its first 0.1 s; and the
    log-log slopes."""
    return {name: _cost_per_step(quick, name) for name in INTEGRATORS}


def _cost_per_step(quick: bool, integrator: str) -> dict:
    counts = (25, 100, 400) if quick else (25, 50, 100, 250, 500, 1000, 2000)
    rows = []
    for n in tqdm(counts, desc=f"{integrator} cost per step", leave=False):
        # under the stability limit at every n (leapfrog's and symplectic Euler's are 0.67 of RK4's)
        step = min(1e-3, 0.25 / n) * (0.6 if integrator in ("leapfrog", "symplectic_euler") else 1.0)
        config = dict(length=4, control_points=n, substeps=1, integrator=integrator, shape="line",
                      start=[0, 0, 0.05], direction=[1, 0, 0.05])
        xml = (f'<mujoco><option timestep="{step}"/>{viscera.extension_xml("rod", **config)}'
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


INTEGRATOR_STYLE = {"rk4": "o-", "leapfrog": "v-", "symplectic_euler": "s-", "implicit": "D-"}


def plot_maps(stability: dict, cost: dict, accuracy: dict, folder: pathlib.Path) -> list[pathlib.Path]:
    """The stability map, the cost per substep and the integrators' speed against accuracy."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 2, figsize=(9.5, 4.1))
    for ax, key, label in ((axes[0], "against_stretch_stiffness", "stretch_stiffness"),
                           (axes[1], "against_control_points", "control_points")):
        drawn = {}
        for integrator, maps in stability.items():
            rows = maps[key]
            x = [r[label] for r in rows]
            y = [r["largest_step_s"] * 1e3 for r in rows]
            capped = all(r["failure"].startswith("stable at") for r in rows)
            same = [other for other, values in drawn.items() if values == y]  # one line would hide the other
            note = " (stable at the 20 ms cap everywhere)" if capped else (f" (= {same[0]})" if same else "")
            style = INTEGRATOR_STYLE.get(integrator, "x-")
            ax.loglog(x, y, style[0] + "--" if same else style, label=integrator + note,
                      **({"markerfacecolor": "none", "markersize": 10} if same else {}))
            drawn[integrator] = y
        ax.axhline(2.0, color="grey", lw=0.8, ls=":")
        ax.annotate("2 ms MuJoCo step", (ax.get_xlim()[0], 2.2), fontsize=7, color="grey")
        # where the defaults sit: 10 N/m, 250 points, and the shipped scenes' 3 substeps per 2 ms
        ax.axvline(10.0 if "stiffness" in label else 250, color="black", lw=0.8, ls="--")
        ax.axhline(2.0 / 3.0, color="tab:orange", lw=0.8, ls="--")
        ax.annotate("default substep (2 ms / 3)", (np.sqrt(ax.get_xlim()[0] * ax.get_xlim()[1]), 0.7), fontsize=7,
                    color="tab:orange", ha="center", va="bottom")
        ax.annotate(" default", (10.0 if "stiffness" in label else 250, ax.get_ylim()[1]), fontsize=7, va="top")
        ax.set_xlabel(label.replace("_", " ") + (" (N/m)" if "stiffness" in label else ""))
        ax.set_ylabel("largest stable substep (ms)")
        ax.grid(True, which="both", alpha=0.3)
    fig.suptitle("stability map (4 m rod, lumped mass, released from 2 % stretch, no damping, no retries)", fontsize=9)
    handles, labels = axes[0].get_legend_handles_labels()  # the same in both panels: one legend, below them
    fig.legend(handles, labels, loc="lower center", ncol=len(labels), fontsize=7)
    fig.tight_layout(rect=(0, 0.07, 1, 1))
    stability_path = folder / "stability_map.png"
    fig.savefig(stability_path, dpi=110)
    plt.close(fig)
    fig, ax = plt.subplots(figsize=(5.2, 3.8))
    for integrator, table in cost.items():
        x = [r["control_points"] for r in table["rows"]]
        y = [r["seconds_per_substep"] * 1e6 for r in table["rows"]]
        ax.loglog(x, y, INTEGRATOR_STYLE.get(integrator, "x-"), label=f"{integrator} (slope {table['slope']:.2f})")
    ax.set_xlabel("control points")
    ax.set_ylabel("wall time per substep (us)")
    ax.set_title("one substep, self-collision on, dropped on a plane", fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    cost_path = folder / "cost_per_step.png"
    fig.savefig(cost_path, dpi=110)
    plt.close(fig)
    fig, ax = plt.subplots(figsize=(5.6, 4.0))
    for integrator, rows in accuracy.items():
        held = [r for r in rows if not r["diverged"]]
        x = [r["wall_s_per_sim_s"] for r in held]
        y = [max(r["error_over_amplitude"], 1e-12) for r in held]
        ax.loglog(x, y, INTEGRATOR_STYLE.get(integrator, "x-"), label=integrator)
        for r, xi, yi in zip(held, x, y):
            ax.annotate(f"{r['step_s'] * 1e3:g}", (xi, yi), textcoords="offset points", xytext=(4, 3), fontsize=6)
        unstable = [f"{r['step_s'] * 1e3:g}" for r in rows if r["diverged"]]
        if unstable:
            ax.plot([], [], " ", label=f"  {integrator} diverged at " + ", ".join(unstable) + " ms")
    ax.set_xlabel("wall seconds per simulated second")
    ax.set_ylabel("position error at 0.25 s / amplitude")
    ax.set_title("speed against accuracy of the integrators (labels: step, ms)\n"
                 "1 m rod, E = 1e5 Pa, released bent, undamped", fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    accuracy_path = folder / "integrators.png"
    fig.savefig(accuracy_path, dpi=110)
    plt.close(fig)
    return [stability_path, cost_path, accuracy_path]
