"""The cavity scene's control loop: real-time factor and per-step latency, with peers.

    python python/tools/bench_cavity.py [--runs 5] [--loads gesture sweep] [--scene anatomical] [--json out.json]

Three loads, each a list of controls replayed on bare MjModel/MjData from a start, timing
every mj_step (the full control loop step: MuJoCo's step and the plugin's compute and advance,
one MuJoCo step: 2 ms in the box abdomen, 1 ms in the anatomical one) with perf_counter_ns, on
the scene --scene names (viscera.tasks.scene.SCENES: abdomen, the default, or anatomical):
  - gesture: the clearing gesture, played once through the clear_area task (seed 0) to record
    its scene, its settled start and its controls (tools moving, the grasper taking and
    releasing holds), then replayed on that scene from that start;
  - rest: the same scene and start with the tools withdrawn and still (every control 0): the
    bowel resting, which sleeping should make nearly free;
  - sweep: the shipped scene, every actuator on a smooth sine within its control range, each at
    its own period (1 + 0.37 i s for actuator i, amplitude 45 % of the range about its middle;
    tests/c/scene_steps.c drives the same), so both tools sweep the cavity, push through the
    bowel and the jaws open and close: the vigorous load.
Peers, run in the same process on the same controls:
  - full: 250 control points, self-collision, both tools, grasping, at the
    defaults (leapfrog with the lumped mass matrix: 3 substeps of one force
    evaluation per 2 ms step; sleeping on);
  - sleep off: the same with `sleep` 0, every control point integrated every step;
  - RK4, consistent mass: the previous defaults (2 RK4 substeps of 4
    evaluations; same controls, so this compares cost, not outcome; the
    consistent matrix and the implicit step below cannot sleep);
  - consistent mass: leapfrog with the paper's band mass matrix (4 substeps:
    its highest frequencies are higher);
  - spheres 1.5 r: collision spheres 18.75 mm apart instead of 12.5 mm (161
    instead of 241; a haptic setup's choice: a 5 mm shaft may then dip 3.3 mm
    between spheres instead of 1.4 mm, tube-tube contact stays exact);
  - implicit, 1 substep: the linearly implicit integrator at one 2 ms substep;
  - half points, soft contacts (the sweep only: its state is smaller, so it cannot start from the
    gesture's): half the control points, laid along the shipped ones as a polyline (its length,
    about 1 % shorter, the same mass), and contacts at half the stiffness and a quarter of the
    damping (1000 N/m, 0.5 N s/m): with these the anatomical bowel's stability estimate allows one
    leapfrog substep per 1 ms step (its elastic mode and contact rate together; at these contacts
    240, 200 and 170 points still take two), so a trade of resolution and contact physics for
    speed, not the same physics;
  - no self-collision: the intestine against the walls and tools only;
  - rigid only: the same scene without the intestine (MuJoCo's own share).
Reported per load and variant, medians over runs: wall seconds per simulated
second (and what sleeping buys: the median over runs of sleep off's time over full's, the two
alternated within each run), real-time factor, step latency percentiles p50, p99, p99.9 and max (ms),
p99.9 / p50 (spikes: a step several times its neighbours), and the p99 ratio to
the full scene. A haptic device at 1 kHz needs p99 under 1 ms.
"""

from __future__ import annotations

import argparse
import json
import re
import statistics
import time
from typing import NamedTuple

import viscera  # first: headless GL backend

import mujoco  # noqa: E402
import numpy as np  # noqa: E402
from tqdm import tqdm  # noqa: E402

from viscera import cli  # noqa: E402
from viscera.tasks import scene  # noqa: E402


class Load(NamedTuple):
    """Controls replayed on a scene from a start."""
    xml: str              # the scene (MJCF text)
    controls: np.ndarray  # every physics step's controls (steps, nu)
    start: dict | None    # qpos, and the intestine's control points (m) and velocities (m/s); None: the model's


def record_gesture(duration: float = 20.0, scene_name: str = "abdomen") -> Load:
    """The clearing gesture through clear_area's seed-0 episode on `scene_name`: its scene, its
    settled start and its controls at every physics step."""
    from viscera.tasks.gesture import ClearingGesture
    env = viscera.tasks.load("clear_area", seed=0, time_limit=duration, end_on_success=False, scene=scene_name)
    policy = ClearingGesture(env)
    step = env.reset()
    model, data = env.physics.model.ptr, env.physics.data.ptr
    guts = viscera.intestines(model)
    start = {"qpos": data.qpos.copy(), "positions": [gut.positions(data).copy() for gut in guts],
             "velocities": [gut.velocities(data).copy() for gut in guts]}
    xml = env.task.scene_xml(env.task.episode)
    substeps = int(round(env.control_timestep() / model.opt.timestep))
    controls = []
    while not step.last():
        step = env.step(policy(step))
        controls += [data.ctrl.copy()] * substeps  # the targets the step drove: the action at the tools' speeds
    return Load(xml, np.array(controls), start)


def record_gesture_controls(duration: float = 20.0) -> np.ndarray:
    """The gesture's controls at every physics step (shape (steps, nu)), as record_gesture."""
    return record_gesture(duration).controls


def sweep_controls(model: mujoco.MjModel, duration: float = 20.0) -> np.ndarray:
    """Every actuator on a sine within its control range (shape (steps, nu)): actuator i at
    period 1 + 0.37 i s, amplitude 45 % of its range about the middle (unlimited ones at 0)."""
    steps = int(round(duration / model.opt.timestep))
    time = np.arange(steps)[:, None] * model.opt.timestep
    low, high = model.actuator_ctrlrange[:, 0], model.actuator_ctrlrange[:, 1]
    period = 1.0 + 0.37 * np.arange(model.nu)
    controls = 0.5 * (low + high) + 0.45 * (high - low) * np.sin(2.0 * np.pi * time / period)
    return np.where(model.actuator_ctrllimited.astype(bool), controls, 0.0)


# config keys each variant adds to the bowel's instance (the scene's first)
VARIANT_CONFIG = {"sleep off": {"sleep": "0"},
                  "RK4, consistent mass": {"integrator": "rk4", "mass_matrix": "consistent", "sleep": "0"},
                  "consistent mass": {"mass_matrix": "consistent", "sleep": "0"},
                  "spheres 1.5 r": {},  # collision_spheres: ceil(length / 1.5 r) + 1, from the scene
                  "implicit, 1 substep": {"integrator": "implicit", "substeps": "1", "sleep": "0"},
                  "no self-collision": {"self_collision": "0"}}


# variants whose state differs from the scene's: timed on loads from the model's own start only
OWN_START_ONLY = ("half points, soft contacts",)


def variant_xml(name: str, text: str | None = None) -> str:
    """A cavity scene (default: the shipped abdomen), whole, with a variant's config keys added to
    its bowel, or with the intestines removed."""
    text = scene.scene_file(scene.ABDOMEN).read_text() if text is None else text
    if name == "spheres 1.5 r":
        gut = viscera.intestines(mujoco.MjModel.from_xml_string(text))[0]
        return scene.with_intestine_config(text, {"collision_spheres": str(int(np.ceil(  # a taper's thin end
            gut.rest_length / (1.5 * min(gut.radius, gut.radius_end)))) + 1)})
    if name == "half points, soft contacts":
        gut = viscera.intestines(mujoco.MjModel.from_xml_string(text))[0]
        points = np.array(gut.config["points"].split(), dtype=float).reshape(-1, 3)
        length = float(np.sum(np.linalg.norm(np.diff(points, axis=0), axis=1)))
        return scene.with_intestine_config(text, {
            "control_points": str(gut.control_count // 2), "shape": "polyline", "length": f"{length * (1 - 1e-6):.6f}",
            "contact_stiffness": "1000", "contact_damping": "0.5"})
    if name in VARIANT_CONFIG:
        return scene.with_intestine_config(text, VARIANT_CONFIG[name])
    if name == "rigid only":
        text = re.sub(r"<extension>.*?</extension>", "", text, flags=re.S)
        return re.sub(r"<sensor>.*?</sensor>", "", text, flags=re.S)
    return text


def time_replay(model: mujoco.MjModel, controls: np.ndarray, start: dict | None = None) -> np.ndarray:
    """Wall time of every mj_step (s) replaying `controls` from `start` (Load.start; None: the
    model's initial state)."""
    data = mujoco.MjData(model)
    if start is not None:
        data.qpos[:] = start["qpos"]
        if model.nplugin:
            for gut, positions, velocities in zip(viscera.intestines(model), start["positions"], start["velocities"]):
                gut.positions(data)[:] = positions
                gut.velocities(data)[:] = velocities
    mujoco.mj_forward(model, data)
    latency = np.empty(len(controls))
    clock = time.perf_counter_ns
    for i, ctrl in enumerate(controls):
        data.ctrl[:] = ctrl
        tick = clock()
        mujoco.mj_step(model, data)
        latency[i] = (clock() - tick) * 1e-9
    return latency


VARIANTS = ("full", "sleep off", "RK4, consistent mass", "consistent mass", "spheres 1.5 r", "implicit, 1 substep",
            "half points, soft contacts", "no self-collision", "rigid only")


LOADS = ("gesture", "rest", "sweep")


def _summary(per_run: list, timestep: float) -> dict:
    def median(f):
        return statistics.median(float(f(r)) for r in per_run)
    return {"wall_s_per_sim_s": median(lambda r: r.sum() / (len(r) * timestep)),
            "p50_ms": median(lambda r: np.percentile(r, 50) * 1e3),
            "p99_ms": median(lambda r: np.percentile(r, 99) * 1e3),
            "p999_ms": median(lambda r: np.percentile(r, 99.9) * 1e3),
            "max_ms": median(lambda r: r.max() * 1e3),
            "p999_over_p50": median(lambda r: np.percentile(r, 99.9) / np.percentile(r, 50))}


def run(runs: int = 5, duration: float = 20.0, quiet: bool = False, loads: tuple = LOADS,
        variants: tuple = VARIANTS, scene_name: str = "abdomen") -> dict:
    loads_run = {}
    if "gesture" in loads or "rest" in loads:
        gesture = record_gesture(duration, scene_name)
        if "gesture" in loads:
            loads_run["gesture"] = gesture
        if "rest" in loads:
            loads_run["rest"] = gesture._replace(controls=np.zeros_like(gesture.controls))
    if "sweep" in loads:
        shipped = variant_xml("full", scene.scene_file(scene.scene_named(scene_name).file).read_text())
        loads_run["sweep"] = Load(shipped, sweep_controls(mujoco.MjModel.from_xml_string(shipped), duration), None)
    models = {load: {name: mujoco.MjModel.from_xml_string(variant_xml(name, entry.xml)) for name in variants
                     if entry.start is None or name not in OWN_START_ONLY}
              for load, entry in loads_run.items()}
    timestep = next(iter(next(iter(models.values())).values())).opt.timestep
    controls = {load: entry.controls for load, entry in loads_run.items()}
    samples = {load: {name: [] for name in models[load]} for load in controls}
    with tqdm(total=runs * sum(len(m) for m in models.values()), desc="replays", disable=quiet) as bar:
        for _ in range(runs):  # interleaved, so machine noise hits every variant alike
            for load, ctrl in controls.items():
                for name in models[load]:
                    samples[load][name].append(time_replay(models[load][name], ctrl, loads_run[load].start))
                    bar.update(1)
    results = {"scene": scene_name, "timestep_s": timestep, "runs": runs, "loads": {}}
    for load in controls:
        results["loads"][load] = {"steps": len(controls[load]), "variants": {
            name: _summary(samples[load][name], timestep) for name in models[load]}}
    if "full" in variants and "sleep off" in variants:  # what sleeping buys: off over on, per load
        results["sleep_savings"] = {load: statistics.median(off.sum() / on.sum() for on, off in zip(
            samples[load]["full"], samples[load]["sleep off"])) for load in controls}
    return results


LOAD_TITLES = {"gesture": "clearing gesture replayed",
               "rest": "the gesture's scene at rest, tools withdrawn",
               "sweep": "every actuator on a sine within its range (vigorous sweep)"}


def report(results: dict) -> str:
    lines = []
    for load, entry in results["loads"].items():
        variants = entry["variants"]
        full = variants.get("full", next(iter(variants.values())))
        lines += [f"{results.get('scene', 'abdomen')} scene, {LOAD_TITLES[load]}: {entry['steps']} steps of "
                  f"{results['timestep_s'] * 1e3:g} ms, medians over {results['runs']} runs",
                  f"{'variant':<30}{'wall s/sim s':>13}{'real time':>11}{'p50 ms':>9}{'p99 ms':>9}{'p99.9 ms':>10}"
                  f"{'max ms':>9}{'p99.9/p50':>11}{'p99 / full':>12}"]
        for name, v in variants.items():
            lines.append(f"{name:<30}{v['wall_s_per_sim_s']:>13.3f}{1.0 / v['wall_s_per_sim_s']:>10.1f}x"
                         f"{v['p50_ms']:>9.3f}{v['p99_ms']:>9.3f}{v['p999_ms']:>10.3f}{v['max_ms']:>9.3f}"
                         f"{v['p999_over_p50']:>11.2f}{v['p99_ms'] / full['p99_ms']:>12.2f}")
        if "sleep_savings" in results:
            lines.append(f"sleeping: {results['sleep_savings'][load]:.2f}x cheaper than sleep off "
                         f"(median over runs of each run's ratio)")
        for name in ("full", "spheres 1.5 r", "implicit, 1 substep"):
            if name in variants:
                p99 = variants[name]["p99_ms"]
                verdict = "meets" if p99 < 1.0 else "misses"
                lines.append(f"{name}: control loop step p99 {p99:.3f} ms, {verdict} the 1 kHz haptic budget (1 ms)")
        lines.append("")
    return "\n".join(lines).rstrip()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python python/tools/bench_cavity.py", description=__doc__.split("\n")[0])
    parser.add_argument("--runs", type=cli.positive_int, default=5,
                        help="replays per variant, medians reported (default 5)")
    parser.add_argument("--duration", type=cli.duration, default=20.0,
                        help="length of each load (simulated s, default 20)")
    parser.add_argument("--loads", nargs="+", choices=LOADS, default=list(LOADS),
                        help="loads to replay (default: both)")
    parser.add_argument("--variants", nargs="+", choices=VARIANTS, default=list(VARIANTS),
                        help="variants to time (default: all)")
    parser.add_argument("--scene", choices=sorted(scene.SCENES), default="abdomen",
                        help="the cavity (default abdomen)")
    parser.add_argument("--json", type=cli.output_file(".json"), help="also write the figures to this JSON file")
    parser.add_argument("--quiet", action="store_true", help="no progress bars")
    args = parser.parse_args(argv)
    results = run(args.runs, args.duration, args.quiet, tuple(args.loads), tuple(args.variants), args.scene)
    print(report(results))
    if args.json:
        with open(args.json, "w") as f:
            json.dump(results, f, indent=2)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
