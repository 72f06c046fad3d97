"""Fingerprints of the simulation's results, to show a change of code left them bit for bit.

    python python/tools/digest.py [--json out.json] [--seeds 2] [--quiet] [--without damage]

Run it in two environments (say, a venv with the previous commit installed and one with
this checkout) and compare the lines: equal lines mean equal results, bit for bit. Each
line is a SHA-256 over the full physics state (mjSTATE_FULLPHYSICS: time, qpos, qvel,
actuator and plugin state) after every step of:
  - fall/*: bench_fall.py's fall (a 4 m, 250-point tube dropped on a plane, 1 s), with
    self-collision on and off, under each integrator;
  - sweep/*: the cavity scene under bench_cavity.py's vigorous sweep (every actuator on a
    sine, 4 s), at the defaults and with each of bench_cavity.py's variants;
  - random/*: each task on seed 5 under uniform random actions (default_rng(11), 100 control
    steps, or until the episode ends), the tools pressing and the jaws working;
  - scripted/*: each task's scripted policy over whole episodes on seeds 1000 and up (unseen
    by the tuning), with the step count and the success.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import pathlib

import viscera  # first: headless GL backend

import mujoco  # noqa: E402
import numpy as np  # noqa: E402
from tqdm import tqdm  # noqa: E402

import bench_cavity  # noqa: E402
import bench_fall  # noqa: E402
import viscera.tasks  # noqa: E402

FULL = mujoco.mjtState.mjSTATE_FULLPHYSICS
INTEGRATORS = ("leapfrog", "rk4", "symplectic_euler", "implicit")


WITHOUT: tuple[str, ...] = ()  # plugin state blocks left out of the hashes (--without)


class StateHash:
    """A running SHA-256 over a model's full physics state, but the intestines' WITHOUT blocks."""

    def __init__(self, model: mujoco.MjModel):
        self.model = model
        self.state = np.empty(mujoco.mj_stateSize(model, FULL))
        self.sha = hashlib.sha256()
        self.keep = np.ones(self.state.size, dtype=bool)
        plugin_state = self.state.size - model.npluginstate  # mjSTATE_PLUGIN comes last in the full state
        for gut in viscera.intestines(model) if WITHOUT else ():
            for block in WITHOUT:
                where = gut.layout[block]
                start = plugin_state + model.plugin_stateadr[gut.instance]
                self.keep[start + where.start:start + where.stop] = False

    def add(self, data: mujoco.MjData) -> None:
        mujoco.mj_getState(self.model, data, self.state, FULL)
        self.sha.update((self.state if not WITHOUT else self.state[self.keep]).tobytes())

    def hexdigest(self) -> str:
        return self.sha.hexdigest()


def replay(model: mujoco.MjModel, controls: np.ndarray | None, steps: int) -> str:
    data = mujoco.MjData(model)
    digest = StateHash(model)
    for i in range(steps):
        if controls is not None:
            data.ctrl[:] = controls[i]
        mujoco.mj_step(model, data)
        digest.add(data)
    return digest.hexdigest()


def fall_cases() -> dict:
    cases = {}
    for self_collision in (1, 0):
        for integrator in INTEGRATORS:
            xml = bench_fall.viscera_xml(self_collision=self_collision)
            xml = xml.replace('<instance name="intestine">',
                              f'<instance name="intestine"><config key="integrator" value="{integrator}"/>', 1)
            assert f'value="{integrator}"' in xml
            cases[f"fall/self_collision={self_collision}/{integrator}"] = (xml, None, 500)
    return cases


def sweep_cases() -> dict:
    cases = {}
    for name in ("full",) + tuple(bench_cavity.VARIANT_CONFIG):
        model = mujoco.MjModel.from_xml_string(bench_cavity.variant_xml(name))
        controls = bench_cavity.sweep_controls(model, 4.0)
        cases[f"sweep/{name}"] = (bench_cavity.variant_xml(name), controls, len(controls))
    return cases


def task_random(name: str) -> str:
    env = viscera.tasks.load(name, seed=5)
    spec = env.action_spec()
    actions = np.random.default_rng(11).uniform(spec.minimum, spec.maximum, (100, spec.shape[0]))
    env.reset()
    digest = StateHash(env.physics.model.ptr)
    for action in actions:
        step = env.step(action)
        digest.add(env.physics.data.ptr)
        if step.last():
            break
    return digest.hexdigest()


def task_scripted(name: str, seed: int) -> str:
    env = viscera.tasks.load(name, seed=seed)
    policy = viscera.tasks.scripted_policy(env)
    step = env.reset()
    digest = StateHash(env.physics.model.ptr)
    steps = 0
    while not step.last():
        step = env.step(policy(step))
        digest.add(env.physics.data.ptr)
        steps += 1
    success = bool(env.task.success(env.physics))
    return f"{digest.hexdigest()} steps={steps} success={success}"


def run(seeds: int = 2, quiet: bool = False) -> dict:
    jobs = []
    for key, (xml, controls, steps) in {**fall_cases(), **sweep_cases()}.items():
        jobs.append((key, lambda xml=xml, controls=controls, steps=steps:
                     replay(mujoco.MjModel.from_xml_string(xml), controls, steps)))
    for name in viscera.tasks.ALL:
        jobs.append((f"random/{name}", lambda name=name: task_random(name)))
        for seed in range(1000, 1000 + seeds):
            jobs.append((f"scripted/{name}/seed={seed}", lambda name=name, seed=seed: task_scripted(name, seed)))
    results = {}
    for key, job in tqdm(jobs, desc="digests", disable=quiet):
        results[key] = job()
    return results


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python python/tools/digest.py", description=__doc__.split("\n")[0])
    parser.add_argument("--seeds", type=int, default=2, help="scripted episodes per task (default 2)")
    parser.add_argument("--json", help="also write the digests to this JSON file")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    parser.add_argument("--without", nargs="+", default=[], metavar="BLOCK",
                        help="leave these plugin state blocks out (say, a block this release adds: damage)")
    args = parser.parse_args(argv)
    global WITHOUT
    WITHOUT = tuple(args.without)
    results = run(args.seeds, args.quiet)
    for key, value in results.items():
        print(f"{key:<48} {value}")
    if args.json:
        pathlib.Path(args.json).write_text(json.dumps(results, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
