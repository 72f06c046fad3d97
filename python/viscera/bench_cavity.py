"""The cavity scene's control loop: real-time factor and per-step latency, with peers.

    python -m viscera.bench_cavity [--runs 5] [--json out.json]

The clearing gesture is played once through the clear_area task to record its
controls (tools moving, the grasper taking and releasing holds); the same
controls are then replayed on bare MjModel/MjData, timing every mj_step (the
full control loop step: MuJoCo's step and the plugin's compute and advance,
one 2 ms step) with perf_counter_ns. Peers, run in the same process on the
same controls:
  - full: 250 control points, self-collision, both tools, grasping;
  - spheres 1.5 r: collision spheres 18.75 mm apart instead of 12.5 mm (161
    instead of 241; a haptic setup's choice: a 5 mm shaft may then dip 3.3 mm
    between spheres instead of 1.4 mm, tube-tube contact stays exact);
  - implicit, 1 substep: the linearly implicit integrator at one 2 ms substep
    instead of RK4 at two (same controls; the bowel then moves differently, so
    this compares cost, not outcome);
  - symplectic Euler, 4 substeps: 4 force evaluations a step instead of 8;
  - no self-collision: the intestine against the walls and tools only;
  - rigid only: the same scene without the intestine (MuJoCo's own share).
Reported per variant, medians over runs: wall seconds per simulated second,
real-time factor, and step latency percentiles p50, p99 and max (ms), with the
ratios to the full scene. A haptic device at 1 kHz needs p99 under 1 ms.
"""

from __future__ import annotations

import argparse
import json
import re
import statistics
import time

import viscera  # first: headless GL backend

import mujoco  # noqa: E402
import numpy as np  # noqa: E402
from tqdm import tqdm  # noqa: E402

from viscera import cli  # noqa: E402
from viscera.tasks import clear_area  # noqa: E402


def record_gesture_controls(duration: float = 20.0) -> np.ndarray:
    """The gesture's controls at every physics step (shape (steps, nu))."""
    from viscera.gesture import ClearingGesture
    env = viscera.tasks.load("clear_area", seed=0, time_limit=duration, end_on_success=False)
    policy = ClearingGesture(env)
    step = env.reset()
    substeps = int(round(env.control_timestep() / env.physics.model.opt.timestep))
    controls = []
    while not step.last():
        action = policy(step)
        controls += [np.asarray(action, dtype=float)] * substeps
        step = env.step(action)
    return np.array(controls)


# config keys each variant adds to the intestine's instance
VARIANT_CONFIG = {"spheres 1.5 r": {"collision_spheres": 161},
                  "implicit, 1 substep": {"integrator": "implicit", "substeps": 1},
                  "symplectic Euler, 4 substeps": {"integrator": "symplectic_euler", "substeps": 4},
                  "no self-collision": {"self_collision": 0}}


def variant_xml(name: str) -> str:
    """The cavity scene, whole, with config keys added, or with the intestine removed."""
    text = clear_area._scene_path().read_text()
    if name in VARIANT_CONFIG:
        added = "".join(f'<config key="{key}" value="{value}"/>\n        '
                        for key, value in VARIANT_CONFIG[name].items())
        return text.replace('<config key="friction"', added + '<config key="friction"', 1)
    if name == "rigid only":
        text = re.sub(r"<extension>.*?</extension>", "", text, flags=re.S)
        return re.sub(r"<sensor>.*?</sensor>", "", text, flags=re.S)
    return text


def time_replay(model: mujoco.MjModel, controls: np.ndarray) -> np.ndarray:
    """Wall time of every mj_step (s) replaying `controls` from the model's initial state."""
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    latency = np.empty(len(controls))
    clock = time.perf_counter_ns
    for i, ctrl in enumerate(controls):
        data.ctrl[:] = ctrl
        tick = clock()
        mujoco.mj_step(model, data)
        latency[i] = (clock() - tick) * 1e-9
    return latency


VARIANTS = ("full", "spheres 1.5 r", "implicit, 1 substep", "symplectic Euler, 4 substeps", "no self-collision",
            "rigid only")


def run(runs: int = 5, duration: float = 20.0, quiet: bool = False) -> dict:
    controls = record_gesture_controls(duration)
    models = {name: mujoco.MjModel.from_xml_string(variant_xml(name)) for name in VARIANTS}
    timestep = models["full"].opt.timestep
    samples = {name: [] for name in VARIANTS}
    with tqdm(total=runs * len(VARIANTS), desc="replays", disable=quiet) as bar:
        for _ in range(runs):  # interleaved, so machine noise hits every variant alike
            for name in VARIANTS:
                samples[name].append(time_replay(models[name], controls))
                bar.update(1)
    results = {"steps": len(controls), "timestep_s": timestep, "runs": runs, "variants": {}}
    for name in VARIANTS:
        per_run = samples[name]
        results["variants"][name] = {
            "wall_s_per_sim_s": statistics.median(float(r.sum()) / (len(r) * timestep) for r in per_run),
            "p50_ms": statistics.median(float(np.percentile(r, 50)) * 1e3 for r in per_run),
            "p99_ms": statistics.median(float(np.percentile(r, 99)) * 1e3 for r in per_run),
            "max_ms": statistics.median(float(r.max()) * 1e3 for r in per_run),
        }
    return results


def report(results: dict) -> str:
    full = results["variants"]["full"]
    lines = [f"cavity scene, clearing gesture replayed: {results['steps']} steps of "
             f"{results['timestep_s'] * 1e3:g} ms, medians over {results['runs']} runs",
             f"{'variant':<30}{'wall s/sim s':>13}{'real time':>11}{'p50 ms':>9}{'p99 ms':>9}{'max ms':>9}"
             f"{'p99 / full':>12}"]
    for name, v in results["variants"].items():
        lines.append(f"{name:<30}{v['wall_s_per_sim_s']:>13.3f}{1.0 / v['wall_s_per_sim_s']:>10.1f}x"
                     f"{v['p50_ms']:>9.3f}{v['p99_ms']:>9.3f}{v['max_ms']:>9.3f}{v['p99_ms'] / full['p99_ms']:>12.2f}")
    for name in ("full", "spheres 1.5 r", "implicit, 1 substep"):
        p99 = results["variants"][name]["p99_ms"]
        verdict = "meets" if p99 < 1.0 else "misses"
        lines.append(f"{name}: control loop step p99 {p99:.3f} ms, {verdict} the 1 kHz haptic budget (1 ms)")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m viscera.bench_cavity", description=__doc__.split("\n")[0])
    parser.add_argument("--runs", type=cli.positive_int, default=5,
                        help="replays per variant, medians reported (default 5)")
    parser.add_argument("--duration", type=cli.positive_float, default=20.0,
                        help="gesture length (simulated s, default 20)")
    parser.add_argument("--json", type=cli.output_file(".json"), help="also write the figures to this JSON file")
    parser.add_argument("--quiet", action="store_true", help="no progress bars")
    args = parser.parse_args(argv)
    results = run(args.runs, args.duration, args.quiet)
    print(report(results))
    if args.json:
        with open(args.json, "w") as f:
            json.dump(results, f, indent=2)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
