"""Validation cases against analytic references, at several resolutions, peers alongside, with charts.

    python -m viscera.validate [--quick] [--no-peers] [--out docs/validation]

Each case builds a MuJoCo model with one intestine (the whole stack: plugin,
core, MuJoCo's step), lets it come to rest under damping (dynamic
relaxation) or rings freely, and compares a measured value with its analytic
reference (formulas in ../shared/NOTES.md):

- catenary: 4 m, ends pinned 3 m apart, the paper's springs with a stiff
  global length term: sag a (cosh(D / 2a) - 1) = 1.177335 m;
- hanging_rod: 1 m of a solid tube of E = 1e5 Pa hanging from its top:
  stretch mu g L^2 / (2 EA) (the springs carry EA = E pi r^2);
- cantilever: 0.5 m, clamped="start", under its own weight, EI from
  young_modulus: tip deflection w L^4 / (8 EI), small (1 % of L);
- tip_load, elastica_alpha_{1,2,5,10}: 0.5 m, EI = 1 N m^2, weightless, a dead
  tip load P = alpha EI / L^2 hung on a grasper: deflection / L = alpha / 3
  (alpha = 0.03), then the elastica's 0.30172, 0.49346, 0.71379, 0.81061;
- vibration_mode_{1,2}: the same beam ringing undamped: (beta L)^2
  sqrt(EI / (mu L^4)) / (2 pi), beta L = 1.87510, 4.69409;
- resting_penetration: a tube on a plane sinks m g / ((S - 1) k) per sphere;
- pile_overlap: the 4 m intestine dropped into a pile: deepest overlap of two
  non-neighbouring parts, as a fraction of the diameter (ideal: 0).
Invariants: the energy drift against the step (its order in dt), and the
length of a hanging intestine with and without the paper's global length term.
Integrators (rk4, leapfrog, symplectic_euler, implicit): the stability map (largest
stable substep against stiffness and resolution), the cost per substep, the
speed against accuracy on a released beam, the stiff catenary and cantilever
at a 2 ms step with each at the fewest substeps that hold, and the energy of
an undamped swinging rod over 100 s.
Peers (viscera.peers: MuJoCo's 1D flexcomp and cable, PyElastica if installed)
run the same cases at their own largest stable steps, in the same process.

Per case and resolution: the value, the reference, the relative error, the
wall seconds per simulated second, and the error's order of convergence in
control points. Static cases do not depend on the step (they are relaxed to
rest). Writes results.json and one Pareto chart per case (error against wall
time), the stability map, the cost per substep and the integrators' speed
against accuracy (integrators.png) into the output folder.
"""

from __future__ import annotations

import argparse
import functools
import json
import pathlib
import time

import viscera  # first: headless GL backend

import mujoco  # noqa: E402
import numpy as np  # noqa: E402
from tqdm import tqdm  # noqa: E402

from viscera.references import (BETA_L, CATENARY_SAG, DENSITY, ELASTICA, G, MU, RADIUS,  # noqa: E402
                                SECOND_MOMENT, peak_frequency)



def _compile(config: dict, timestep: float, gravity=(0.0, 0.0, -G), worldbody: str = ""):
    xml = (f'<mujoco><option timestep="{timestep}" gravity="{gravity[0]} {gravity[1]} {gravity[2]}"/>'
           f'{viscera.extension_xml("rod", **config)}<worldbody>{worldbody}</worldbody></mujoco>')
    model = mujoco.MjModel.from_xml_string(xml)
    return model, mujoco.MjData(model), viscera.intestine(model)


def _relax(config: dict, duration: float, timestep: float, gravity=(0.0, 0.0, -G), worldbody: str = "",
           setup=None):
    """Compile and step an intestine for `duration` s; return its data, intestine, wall s per sim s.
    `setup(model, data)`, if given, runs before the first step (loads, initial velocities)."""
    model, data, gut = _compile(config, timestep, gravity, worldbody)
    if setup:
        setup(model, data)
    steps = int(round(duration / timestep))
    start = time.perf_counter()
    for _ in range(steps):
        mujoco.mj_step(model, data)
    wall = time.perf_counter() - start
    if gut.divergence_count(data):
        raise RuntimeError(f"diverged: {config}")
    return data, gut, wall / (steps * timestep)


def _substeps(n: int, length: float, rigidity: float, axial: float = 0.0, extra_rate: float = 0.0,
              step: float = 1e-3) -> int:
    """RK4 substeps per `step` (s) under the stability limit of the stiffest mode: curvature
    (EI, N m^2) and axial (EA, N) waves at the sample spacing, and `extra_rate` (rad/s)."""
    spacing = length / (2 * (n - 1))  # sample spacing (m), 2 samples per segment
    bending = 2.0 * np.sqrt(rigidity / (MU * spacing**4))
    stretch = 2.0 * np.sqrt(axial / MU) / spacing
    return int(np.ceil(step * max(bending, stretch, extra_rate) / 1.5))


def catenary(n: int, integrator: str = "rk4", timestep: float = 0.001, substeps: int = 2,
             stretch_stiffness: float = 100.0) -> dict:
    depth = np.sqrt(2.0**2 - 1.5**2)  # a V of the rod's length
    config = dict(length=4, control_points=n, stretch_stiffness=stretch_stiffness, bend_stiffness=0,
                  global_stretch_stiffness=5000, damping=4, substeps=substeps, integrator=integrator,
                  divergence_retries=0, self_collision=0, shape="polyline",
                  points=[-1.5, 0, 0, 0, 0, -depth, 1.5, 0, 0], pinned=[0, n - 1])
    data, gut, cost = _relax(config, 6.0, timestep)
    sag = -gut.axis_points(data, 20001)[:, 2].min()
    return {"value": sag, "reference": CATENARY_SAG, "unit": "m", "wall_s_per_sim_s": cost}


def hanging_rod(n: int) -> dict:
    young, length = 1.0e5, 1.0
    area = np.pi * RADIUS**2
    config = dict(length=length, control_points=n, radius=RADIUS, density=DENSITY, young_modulus=young, damping=6,
                  substeps=2, self_collision=0, shape="line", direction=[0, 0, -1], pinned=[0])
    data, gut, cost = _relax(config, 5.0, 0.001)
    reference = MU * G * length**2 / (2.0 * young * area)
    return {"value": gut.length(data) - length, "reference": reference, "unit": "m", "wall_s_per_sim_s": cost}




def cantilever(n: int, integrator: str = "rk4", timestep: float = 0.001, substeps: int | None = None) -> dict:
    """0.5 m clamped (config clamped="start") under its own weight, EI for a 1 % tip deflection.
    `substeps` per `timestep` (s); by default RK4's under its stability limit at 1 ms."""
    length, tip_fraction = 0.5, 0.01
    rigidity = MU * G * length**4 / (8.0 * tip_fraction * length)
    # the axis barely stretches here: a softer EA (raw stiffness wins) keeps the step affordable
    substeps = substeps or _substeps(n, length, rigidity)
    config = dict(length=length, control_points=n, radius=RADIUS, density=DENSITY,
                  young_modulus=rigidity / SECOND_MOMENT, stretch_stiffness=2000, damping=30, substeps=substeps,
                  integrator=integrator, divergence_retries=0, self_collision=0, shape="line", direction=[1, 0, 0],
                  clamped="start")
    data, gut, cost = _relax(config, 0.6, timestep)
    tip = gut.axis_points(data, 2)[-1]
    return {"value": -tip[2], "reference": MU * G * length**4 / (8.0 * rigidity), "unit": "m",
            "wall_s_per_sim_s": cost, "substeps": substeps}


# Tip-loaded cantilever: 0.5 m, EI = 1 N m^2, weightless (gravity off), EA from the same E.
TIP_LENGTH, TIP_RIGIDITY = 0.5, 1.0
GRASP_STIFFNESS = 2.0e4  # N/m: the hook holding the load stretches P / k (2 mm at 40 N)


def tip_load(n: int, alpha: float) -> dict:
    """A free body hooked to the tip by a grasper (the whole stack: site, jaw joint, hold
    spring) and pushed down by a constant xfrc_applied P = alpha EI / L^2 (a dead load).
    Reference: alpha / 3 (linear) below alpha = 0.1, else the elastica table."""
    length, rigidity = TIP_LENGTH, TIP_RIGIDITY
    young = rigidity / SECOND_MOMENT
    axial = young * np.pi * RADIUS**2
    load = alpha * rigidity / length**2
    tip_mass = MU * length / (n - 1) / 3.0  # about the consistent mass at the end control point
    substeps = _substeps(n, length, rigidity, axial, np.sqrt(GRASP_STIFFNESS / tip_mass))
    config = dict(length=length, control_points=n, radius=RADIUS, density=DENSITY, young_modulus=young, damping=30,
                  substeps=substeps, self_collision=0, shape="line", direction=[1, 0, 0], clamped="start",
                  grasp_sites="hook", grasp_joints="jaw", grasp_stiffness=GRASP_STIFFNESS, grasp_damping=2,
                  grasp_slip_force=1e9)
    # the load: 1 kg on slide joints (no rotation to settle), damped about critically on the
    # beam's tip stiffness 3 EI / L^3; the jaw is a hinge nothing turns, so it never opens.
    # (A 0.1 kg load oscillated and grew: the hold's force reaches MuJoCo once per step.)
    worldbody = (f'<body name="load" pos="{length} 0 0">'
                 '<joint type="slide" axis="1 0 0" damping="10"/><joint type="slide" axis="0 1 0" damping="10"/>'
                 '<joint type="slide" axis="0 0 1" damping="10"/>'
                 '<geom type="sphere" size="0.005" mass="1" contype="0" conaffinity="0"/><site name="hook"/>'
                 '<body name="jaw"><joint name="jaw" type="hinge" axis="1 0 0"/>'
                 '<geom type="sphere" size="0.002" mass="0.001" contype="0" conaffinity="0"/></body></body>')

    def hang(model, data):
        data.xfrc_applied[model.body("load").id, 2] = -load

    data, gut, cost = _relax(config, 4.0, 0.001, gravity=(0, 0, 0), worldbody=worldbody, setup=hang)
    if gut.grasps(data)[0].status != "holding":
        raise RuntimeError("the hook let go of the tip")
    deflection = -gut.axis_points(data, 2)[-1][2] / length
    reference = alpha / 3.0 if alpha < 0.1 else ELASTICA[alpha]
    return {"value": deflection, "reference": reference, "unit": "L", "wall_s_per_sim_s": cost,
            "substeps": substeps, "load_N": load, "axial_strain": load / axial}




@functools.lru_cache(maxsize=None)
def _vibration_run(n: int) -> tuple[float, float, float]:
    """Free vibration of the weightless tip-load cantilever, undamped, from a kick on its outer
    quarter: the first two frequencies (Hz) and the wall s per sim s."""
    length, rigidity = TIP_LENGTH, TIP_RIGIDITY
    young = rigidity / SECOND_MOMENT
    first = BETA_L[0]**2 * np.sqrt(rigidity / (MU * length**4)) / (2 * np.pi)
    substeps = _substeps(n, length, rigidity, young * np.pi * RADIUS**2)
    config = dict(length=length, control_points=n, radius=RADIUS, density=DENSITY, young_modulus=young, damping=0,
                  substeps=substeps, self_collision=0, shape="line", direction=[1, 0, 0], clamped="start")
    model, data, gut = _compile(config, 1e-3, gravity=(0, 0, 0))
    velocities = gut.velocities(data)
    velocities[int(0.75 * n):, 2] = 1e-3  # m/s: deflections stay ~1e-4 L, linear
    steps = int(round(30.0 / first / 1e-3))  # 30 periods of the first mode
    tip = np.empty(steps)
    start = time.perf_counter()
    for i in range(steps):
        mujoco.mj_step(model, data)
        tip[i] = gut.positions(data)[-1, 2]
    cost = (time.perf_counter() - start) / (steps * 1e-3)
    ratio = (BETA_L[1] / BETA_L[0])**2
    return (peak_frequency(tip, 1e-3, 0.5 * first, 1.5 * first),
            peak_frequency(tip, 1e-3, 0.5 * ratio * first, 1.5 * ratio * first), cost)


def vibration(n: int, mode: int) -> dict:
    rigidity, length = TIP_RIGIDITY, TIP_LENGTH
    reference = BETA_L[mode - 1]**2 * np.sqrt(rigidity / (MU * length**4)) / (2 * np.pi)
    frequencies = _vibration_run(n)
    return {"value": frequencies[mode - 1], "reference": reference, "unit": "Hz", "wall_s_per_sim_s": frequencies[2]}


def resting_penetration(n: int) -> dict:
    """A 1 m tube lying on a plane: the interior spheres' penetration against the penalty's
    m g / ((S - 1) k) (S spheres of stiffness k share the weight)."""
    config = dict(length=1.0, control_points=n, damping=5, shape="line", start=[0, 0, 0.1], direction=[1, 0, 0])
    data, gut, cost = _relax(config, 3.0, 0.001, worldbody='<geom type="plane" size="3 3 0.1"/>')
    penetration = gut.radius - gut.sphere_centres(data)[:, 2]
    weight = DENSITY * np.pi * RADIUS**2 * 1.0 * G
    reference = weight / ((gut.sphere_count - 1) * 2000.0)  # default contact_stiffness, N/m
    return {"value": float(np.median(penetration[gut.sphere_count // 8:-gut.sphere_count // 8])),
            "reference": reference, "unit": "m", "wall_s_per_sim_s": cost,
            "fraction_of_radius": float(penetration.max() / gut.radius)}


def pile_overlap(n: int) -> dict:
    """The 4 m intestine dropped into a pile on a plane, 5 s: the deepest overlap of two
    non-neighbouring parts of the tube, as a fraction of its diameter (reference: none)."""
    config = dict(length=4, control_points=n, shape="serpentine", box=[-0.1, -0.1, 0.05, 0.1, 0.1, 0.8])
    data, gut, cost = _relax(config, 5.0, 0.002, worldbody='<geom type="plane" size="2 2 .1"/>')
    count = 2 * (gut.sphere_count - 1) + 1
    x = gut.axis_points(data, count)
    arc = np.linspace(0.0, gut.rest_length, count)
    closest = np.inf
    for i in range(0, count, 64):  # blocks: the full distance matrix would be 400 MB at n = 1000
        d = np.linalg.norm(x[i:i + 64, None, :] - x[None, :, :], axis=-1)
        far = np.abs(arc[i:i + 64, None] - arc[None, :]) >= np.pi * gut.radius
        closest = min(closest, d[far].min())
    overlap = max(0.0, 2 * gut.radius - closest) / (2 * gut.radius)
    return {"value": overlap, "reference": 0.0, "unit": "diameter", "wall_s_per_sim_s": cost,
            "absolute_error": True, "top_m": float(x[:, 2].max())}


def _stable(config: dict, step: float, seconds: float = 0.2, integrator: str = "rk4") -> str:
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
    failure = _stable(config, high, integrator=integrator)
    if failure == "stable":
        return high, "stable at 20 ms"
    for _ in range(14):
        middle = np.sqrt(low * high)
        outcome = _stable(config, middle, integrator=integrator)
        if outcome == "stable":
            low = middle
        else:
            high, failure = middle, outcome
    return low, failure


INTEGRATORS = viscera.allowed_values("integrator")  # the plugin's list


class _quiet_warnings:
    """Silence the plugin's divergence warnings, expected where a run probes a limit."""

    def __enter__(self):
        mujoco.set_mju_user_warning(lambda message: None)

    def __exit__(self, *exc):
        mujoco.set_mju_user_warning(None)


def stability_map(quick: bool = False) -> dict:
    """Largest stable substep of each integrator against stretch stiffness (250 points) and
    against control points (default stiffness), 4 m rod, no damping, no contact, no retries."""
    with _quiet_warnings():
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


def fewest_substeps(case, limit: int = 512) -> tuple[int, dict]:
    """The fewest substeps (powers of two) at which `case(substeps)` runs without diverging, and
    its row; (0, {}) if even `limit` diverges."""
    substeps = 1
    with _quiet_warnings():
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
            substeps, row = fewest_substeps(functools.partial(case, integrator))
            if row:
                row["relative_error"] = abs(row["value"] - row["reference"]) / abs(row["reference"])
            rows.append(dict(row, case=name, integrator=integrator, substeps=substeps, step_s=0.002))
    return rows


def _unstretched_half_sine(n: int, amplitude: float) -> np.ndarray:
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
        model, data, gut = _compile(config, step, gravity=(0, 0, 0))
        gut.positions(data)[:] = _unstretched_half_sine(gut.control_count, 0.05)
        count = int(round(0.25 / step))
        start = time.perf_counter()
        for _ in range(count):
            mujoco.mj_step(model, data)
        wall = (time.perf_counter() - start) / (count * step)
        return gut.positions(data).copy(), gut.divergence_count(data) > 0, wall

    with _quiet_warnings():
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
        model, data, gut = _compile(config, 0.002)
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


def energy_drift(step: float, duration: float = 1.0) -> dict:
    """A 1 m rod (E = 1e5 Pa, EI and EA) bent into half a sine wave of 5 cm and released without
    gravity, damping or contact: the largest relative change of its total energy over `duration`
    s at the RK4 step `step` (s, one substep per MuJoCo step)."""
    config = dict(length=1.0, control_points=25, young_modulus=1e5, damping=0, substeps=1, self_collision=0,
                  shape="line", direction=[1, 0, 0], integrator="rk4")
    model, data, gut = _compile(config, step, gravity=(0, 0, 0))
    positions = gut.positions(data)
    positions[:, 2] = 0.05 * np.sin(np.pi * positions[:, 0])
    start_energy = sum(gut.energy(data).values())
    worst, steps = 0.0, int(round(duration / step))
    start = time.perf_counter()
    for i in range(steps):
        mujoco.mj_step(model, data)
        if i % max(1, steps // 50) == 0 or i == steps - 1:
            worst = max(worst, abs(sum(gut.energy(data).values()) / start_energy - 1.0))
    return {"step_s": step, "relative_energy_drift": worst, "diverged": gut.divergence_count(data) > 0,
            "wall_s_per_sim_s": (time.perf_counter() - start) / duration}


def energy_drift_order(quick: bool = False) -> dict:
    """Energy drift at halving steps and the observed order. RK4 loses (omega h)^6 / 72 of an
    oscillation's energy per step, so over a fixed time its drift is O(h^5), one order better
    than its phase error."""
    steps = (4e-4, 2e-4, 1e-4) if quick else (8e-4, 4e-4, 2e-4, 1e-4)
    rows = [energy_drift(h) for h in tqdm(steps, desc="energy drift", leave=False)]
    a, b = rows[-2], rows[-1]
    order = float(np.log(a["relative_energy_drift"] / b["relative_energy_drift"]) / np.log(a["step_s"] / b["step_s"]))
    return {"integrator": "rk4", "rows": rows, "order_in_dt": order}


def length_preservation() -> dict:
    """The default 4 m intestine (the paper's springs) hanging from one end, at rest: its
    relative stretch with the global length term (default 200 N/m) and without it."""
    out = {}
    for label, global_stiffness in (("with_global_stretch", 200.0), ("without_global_stretch", 0.0)):
        config = dict(length=4.0, control_points=50, damping=5, substeps=2, self_collision=0, shape="line",
                      direction=[0, 0, -1], pinned=[0], global_stretch_stiffness=global_stiffness)
        data, gut, cost = _relax(config, 6.0, 0.001)
        out[label] = {"relative_stretch": gut.length(data) / 4.0 - 1.0, "global_stretch_stiffness": global_stiffness,
                      "wall_s_per_sim_s": cost}
    return out


CASES = {"catenary": (catenary, (25, 50, 100, 200)),
         "hanging_rod": (hanging_rod, (10, 20, 40, 80)),
         "cantilever": (cantilever, (8, 16, 32, 48)),
         "tip_load": (functools.partial(tip_load, alpha=0.03), (8, 16, 32)),
         "elastica_alpha_1": (functools.partial(tip_load, alpha=1.0), (8, 16, 32)),
         "elastica_alpha_2": (functools.partial(tip_load, alpha=2.0), (8, 16, 32)),
         "elastica_alpha_5": (functools.partial(tip_load, alpha=5.0), (8, 16, 32)),
         "elastica_alpha_10": (functools.partial(tip_load, alpha=10.0), (8, 16, 32)),
         "vibration_mode_1": (functools.partial(vibration, mode=1), (8, 16, 32)),
         "vibration_mode_2": (functools.partial(vibration, mode=2), (8, 16, 32)),
         "resting_penetration": (resting_penetration, (20, 40, 80)),
         "pile_overlap": (pile_overlap, (125, 250)),
         }


def run(quick: bool = False, quiet: bool = False, peers: bool = True) -> tuple[dict, dict]:
    """Every case at its resolutions (two with `quick`), and the available peers on the same
    cases (their smallest resolution with `quick`). Returns (ours, peers): per case, rows of
    value, reference, relative error and wall s per sim s; peers per case and peer."""
    jobs = [("viscera", name, n) for name, (_, sizes) in CASES.items() for n in (sizes[:2] if quick else sizes)]
    if peers:
        from viscera import peers as peer_module
        for peer in peer_module.PEERS:
            if not peer_module.available(peer):
                continue
            for name in CASES:
                sizes = peer_module.RESOLUTIONS.get(name, ())
                jobs += [(peer, name, n) for n in (sizes[:1] if quick else sizes)]
    results: dict = {name: [] for name in CASES}
    peer_results: dict = {name: {} for name in CASES}
    for who, name, n in tqdm(jobs, desc="validation", disable=quiet):
        if who == "viscera":
            row = CASES[name][0](n)
            row["control_points"] = n
        else:
            row = peer_module.run_peer(who, name, n)
            if "unsupported" in row:
                peer_results[name][who] = row
                continue
            peer_results[name].setdefault(who, [])
        scale = 1.0 if row.pop("absolute_error", False) else abs(row["reference"])
        row["relative_error"] = abs(row["value"] - row["reference"]) / scale
        (results[name] if who == "viscera" else peer_results[name][who]).append(row)
    for name, rows in results.items():
        # observed order: slope of log error against log n over the first two resolutions, before
        # the error meets the floor a case's own physics sets (stretch, geometric nonlinearity)
        if len(rows) >= 2:
            a, b = rows[0], rows[1]
            if a["relative_error"] > 0 and b["relative_error"] > 0:
                rows[1]["order_in_control_points"] = float(
                    -np.log(b["relative_error"] / a["relative_error"]) / np.log(b["control_points"] / a["control_points"]))
    return results, peer_results


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


PEER_STYLE = {"mujoco_flexcomp": "s--", "mujoco_cable": "^--", "pyelastica": "D--"}


def plot(results: dict, peer_results: dict, folder: pathlib.Path) -> list[pathlib.Path]:
    """One Pareto chart per case: relative error against wall s per sim s, ours at each
    resolution and the peers at theirs."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    paths = []
    for name, rows in results.items():
        if not rows:
            continue
        fig, ax = plt.subplots(figsize=(5.2, 3.8))
        x = [r["wall_s_per_sim_s"] for r in rows]
        y = [max(r["relative_error"], 1e-9) for r in rows]
        ax.loglog(x, y, "o-", label="viscera (leapfrog, lumped M), n control points")
        for r, xi, yi in zip(rows, x, y):
            ax.annotate(f"{r['control_points']}", (xi, yi), textcoords="offset points", xytext=(4, 4), fontsize=7)
        unsupported = []
        for peer, peer_rows in peer_results.get(name, {}).items():
            if isinstance(peer_rows, dict):
                unsupported.append(peer)
                continue
            px = [r["wall_s_per_sim_s"] for r in peer_rows]
            py = [max(r["relative_error"], 1e-9) for r in peer_rows]
            ax.loglog(px, py, PEER_STYLE.get(peer, "x--"), label=f"{peer}, segments")
            for r, xi, yi in zip(peer_rows, px, py):
                ax.annotate(f"{r['segments']}", (xi, yi), textcoords="offset points", xytext=(4, -9), fontsize=7)
        ax.set_xlabel("wall seconds per simulated second")
        ax.set_ylabel("relative error" if name != "pile_overlap" else "overlap / diameter")
        title = name.replace("_", " ")
        if unsupported:
            title += "\n(cannot express it: " + ", ".join(unsupported) + ")"
        ax.set_title(title, fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
        fig.tight_layout()
        path = folder / f"pareto_{name}.png"
        fig.savefig(path, dpi=110)
        plt.close(fig)
        paths.append(path)
    return paths


def report(results: dict, peer_results: dict | None = None) -> str:
    lines = [f"{'case':<20}{'model':<17}{'n':>5}{'value':>13}{'reference':>13}{'rel. error':>12}{'wall s/sim s':>14}"
             f"{'order':>7}"]
    for name, rows in results.items():
        for r in rows:
            order = f"{r['order_in_control_points']:.2f}" if "order_in_control_points" in r else ""
            lines.append(f"{name:<20}{'viscera':<17}{r['control_points']:>5}{r['value']:>13.6g}{r['reference']:>13.6g}"
                         f"{r['relative_error']:>12.2e}{r['wall_s_per_sim_s']:>14.4f}{order:>7}")
        for peer, peer_rows in (peer_results or {}).get(name, {}).items():
            if isinstance(peer_rows, dict):
                lines.append(f"{name:<20}{peer:<17}  cannot express it: {peer_rows['unsupported']}")
                continue
            for r in peer_rows:
                lines.append(f"{name:<20}{peer:<17}{r['segments']:>5}{r['value']:>13.6g}{r['reference']:>13.6g}"
                             f"{r['relative_error']:>12.2e}{r['wall_s_per_sim_s']:>14.4f}"
                             f"   (step {r['timestep_s'] * 1e3:.3g} ms)")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m viscera.validate", description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="two resolutions per case, peers at one")
    parser.add_argument("--no-peers", action="store_true", help="our model only")
    parser.add_argument("--out", type=pathlib.Path, default=pathlib.Path("docs") / "validation",
                        help="folder for results.json and the charts (default docs/validation)")
    parser.add_argument("--quiet", action="store_true", help="no progress bars")
    args = parser.parse_args(argv)
    results, peer_results = run(args.quick, args.quiet, peers=not args.no_peers)
    drift = energy_drift_order(args.quick)
    lengths = length_preservation()
    stability = stability_map(args.quick)
    cost = cost_per_step(args.quick)
    accuracy = integrator_accuracy(args.quick)
    stiff = stiff_comparison(args.quick)
    bounds = energy_bounds(20.0 if args.quick else 100.0)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "results.json").write_text(json.dumps(
        {"cases": results, "peers": peer_results, "energy_drift": drift, "length_preservation": lengths,
         "stability_map": stability, "cost_per_step": cost, "integrator_accuracy": accuracy,
         "stiff_comparison": stiff, "energy_bounds": bounds}, indent=2))
    plot(results, peer_results, args.out)
    plot_maps(stability, cost, accuracy, args.out)
    print(report(results, peer_results))
    print("energy drift over 1 s (RK4, no damping): " + ", ".join(
        f"{r['step_s'] * 1e3:.2g} ms: {r['relative_energy_drift']:.2e}" for r in drift["rows"])
        + f"; order in dt {drift['order_in_dt']:.2f}")
    print("hanging 4 m intestine, relative stretch: " + ", ".join(
        f"{k.replace('_', ' ')}: {v['relative_stretch']:.4f}" for k, v in lengths.items()))
    for integrator, maps in stability.items():
        for key, label in (("against_stretch_stiffness", "stretch_stiffness"), ("against_control_points", "control_points")):
            print(f"{integrator} largest stable substep vs {label}: " + ", ".join(
                f"{r[label]}: {r['largest_step_s'] * 1e3:.3g} ms ({r['failure']})" for r in maps[key]))
    for integrator, table in cost.items():
        print(f"{integrator} cost per substep (us): " + ", ".join(
            f"n={r['control_points']}: {r['seconds_per_substep'] * 1e6:.1f}" for r in table["rows"])
            + f"; log-log slope {table['slope']:.2f}")
    for integrator, rows in accuracy.items():
        print(f"{integrator} error at 0.25 s / amplitude: " + ", ".join(
            f"{r['step_s'] * 1e3:g} ms: " + ("diverged" if r["diverged"] else
                                            f"{r['error_over_amplitude']:.2e} ({r['wall_s_per_sim_s']:.3f} s/s)")
            for r in rows))
    for r in stiff:
        print(f"{r['case']}, {r['integrator']}: " + (f"{r['substeps']} substeps at 2 ms, error "
              f"{r['relative_error']:.2e}, {r['wall_s_per_sim_s']:.3f} wall s/sim s" if r["substeps"]
              else "diverged at every substep count tried"))
    for integrator, row in bounds.items():
        print(f"{integrator} ({row['substeps']} substeps at 2 ms), energy error / swing energy: first half "
              f"{row['first_half']:.3g}, second half {row['second_half']:.3g}")
    print(f"wrote {args.out / 'results.json'} and the charts")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
