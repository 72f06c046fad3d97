"""A seed and the scripted policy play the same episode, bit for bit, whatever SIMD features numpy
finds and whatever kernel OpenBLAS picks (viscera.numerics says why they could differ).

Short scripted episodes of every task are played in fresh interpreters: one as the machine is, and
others as on older CPUs, numpy's AVX-512 (then every non-baseline) dispatch turned off with
NPY_DISABLE_CPU_FEATURES and OpenBLAS held to an older kernel with OPENBLAS_CORETYPE. Every step's
action and observation and the final mjSTATE_FULLPHYSICS state must be the same bits.

Not switched here: glibc's libm variants (GLIBC_TUNABLES=glibc.cpu.hwcaps=-AVX2,-FMA). MuJoCo and
the plugin call libm in every step, so with the same actions the physics itself differs under that
switch (viscera.numerics): no Python arithmetic could make such an episode the same.
"""

from __future__ import annotations

import json
import os
import pathlib
import re
import subprocess
import sys

import numpy as np
import pytest

import viscera

# (task, seed, time limit s): long enough for each policy's planning and re-planning from the
# observations: clear_area's gesture plans its first carry and, from the coverage it left, a second
# (it withdraws 6 s before the limit); retract_reach clears the spot, retracts and reaches;
# grasp_lift grasps and lifts; run_the_bowel takes the mark and hands over once. Each of these
# episodes differed under the switches before viscera.numerics (from step 1 to 236 on).
EPISODES = (("clear_area", 0, 15.0), ("clear_area", 1, 15.0), ("grasp_lift", 2, 6.0), ("grasp_lift", 3, 6.0),
            ("retract_reach", 0, 11.0), ("retract_reach", 1, 11.0), ("run_the_bowel", 0, 8.0),
            ("run_the_bowel", 3, 8.0))

CHILD = r"""
import hashlib, json, sys
import numpy as np
try:
    from numpy._core import _multiarray_umath as umath
except ImportError:  # numpy 1
    from numpy.core import _multiarray_umath as umath
import viscera.tasks
from viscera.recording import final_state_sha256

def sha(array):
    return hashlib.sha256(np.ascontiguousarray(array, dtype=float).tobytes()).hexdigest()

probe = np.random.RandomState(0).uniform(-1.0, 1.0, (1000, 3))
out = {"features": [name for name in umath.__cpu_dispatch__ if umath.__cpu_features__.get(name)],
       # what the switches change: a vector's norm is a BLAS dot product, np.arcsin a SIMD kernel
       "blas_probe": sha([np.linalg.norm(v) for v in probe]), "simd_probe": sha(np.arcsin(probe[:, 0])),
       "episodes": {}}
for name, seed, time_limit in json.loads(sys.argv[1]):
    env = viscera.tasks.load(name, seed=seed, time_limit=time_limit)
    policy = viscera.tasks.scripted_policy(env)
    step = env.reset()
    actions, observations = [], [sha(np.concatenate([np.ravel(v) for v in step.observation.values()]))]
    while not step.last():
        action = np.asarray(policy(step), dtype=float)
        actions.append(action.tobytes().hex())
        step = env.step(action)
        observations.append(sha(np.concatenate([np.ravel(v) for v in step.observation.values()])))
    out["episodes"][f"{name} {seed}"] = {"actions": actions, "observations": observations,
                             "final_state": final_state_sha256(env.physics)}
print(json.dumps(out))
"""


def _dispatch_features() -> list[str]:
    try:
        from numpy._core import _multiarray_umath as umath
    except ImportError:  # numpy 1
        from numpy.core import _multiarray_umath as umath
    return list(umath.__cpu_dispatch__)


def _switches() -> dict[str, dict[str, str]]:
    """The environments of the runs, by name: the machine as it is, and as older CPUs would run
    numpy and OpenBLAS (only names numpy dispatches on: it refuses its baseline's)."""
    dispatch = _dispatch_features()
    return {
        "as is": {},
        "no AVX-512, Sandybridge BLAS": {"NPY_DISABLE_CPU_FEATURES": " ".join(f for f in dispatch if "AVX512" in f),
                                         "OPENBLAS_CORETYPE": "Sandybridge"},
        "numpy baseline only (no AVX2, FMA3, AVX), Prescott BLAS": {"NPY_DISABLE_CPU_FEATURES": " ".join(dispatch),
                                                                    "OPENBLAS_CORETYPE": "Prescott"},
    }


@pytest.fixture(scope="module")
def runs() -> dict[str, dict]:
    """Each run's output, the runs side by side (each a fresh interpreter: the switches are read
    when numpy and OpenBLAS load)."""
    processes = {}
    for name, switches in _switches().items():
        env = {key: value for key, value in os.environ.items()
               if key not in ("NPY_DISABLE_CPU_FEATURES", "NPY_ENABLE_CPU_FEATURES", "OPENBLAS_CORETYPE")}
        processes[name] = subprocess.Popen([sys.executable, "-c", CHILD, json.dumps(EPISODES)],
                                           env=dict(env, **switches), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                           text=True)
    outputs = {}
    for name, process in processes.items():
        stdout, stderr = process.communicate(timeout=600)
        assert process.returncode == 0, f"the run {name!r} failed:\n{stderr[-3000:]}"
        outputs[name] = json.loads(stdout.strip().splitlines()[-1])
    return outputs


def test_the_switches_take_effect(runs):
    """The runs differ where they should: numpy dispatches on none of the features turned off, and
    OpenBLAS's older kernels give other bits for a vector's norm (else the episodes' test below
    would compare a machine with itself)."""
    for name, switches in _switches().items():
        still = set(switches.get("NPY_DISABLE_CPU_FEATURES", "").split()) & set(runs[name]["features"])
        assert not still, f"{name}: numpy still dispatches on {sorted(still)}"
    reference, others = runs["as is"], [run for name, run in runs.items() if name != "as is"]
    assert any(run["blas_probe"] != reference["blas_probe"] for run in others), \
        "OPENBLAS_CORETYPE changed no bit of a BLAS norm: is numpy's BLAS OpenBLAS?"
    if "AVX512_SKX" in reference["features"]:  # np.arcsin's SVML kernel, where numpy has it
        assert all(run["simd_probe"] != reference["simd_probe"] for run in others), \
            "turning numpy's AVX-512 off changed no bit of np.arcsin"


@pytest.mark.parametrize("task", [f"{name} {seed}" for name, seed, _ in EPISODES])
def test_the_same_episode_on_any_cpu(runs, task):
    """`task` (its name and seed): every step's action and observation and the final state."""
    reference = runs["as is"]["episodes"][task]
    for name, run in runs.items():
        episode = run["episodes"][task]
        actions, expected = episode["actions"], reference["actions"]
        differ = [i for i, (a, b) in enumerate(zip(actions, expected)) if a != b]
        if differ:
            i = differ[0]
            got, want = np.frombuffer(bytes.fromhex(actions[i]), dtype=float), np.frombuffer(bytes.fromhex(expected[i]),
                                                                                            dtype=float)
            pytest.fail(f"{task}, {name}: the action of step {i} differs ({len(differ)} steps of {len(expected)} do):\n"
                        f"  {got.tolist()}\n  as is: {want.tolist()}\n  difference: {(got - want).tolist()}")
        assert len(actions) == len(expected), f"{task}, {name}: {len(actions)} steps, as is {len(expected)}"
        observations = [i for i, (a, b) in enumerate(zip(episode["observations"], reference["observations"])) if a != b]
        assert not observations, f"{task}, {name}: observation {observations[0]} (0: the reset's) differs"
        assert episode["final_state"] == reference["final_state"], f"{task}, {name}: the final state differs"


# numpy calls whose last bits depend on the CPU (viscera.numerics): BLAS (a vector's norm without
# `axis` is a dot product) and the transcendental ufuncs
CPU_DEPENDENT = re.compile(r"np\.linalg\.norm\(|np\.(dot|vdot|inner|matmul|tensordot|einsum)\(|"
                           r"np\.(sin|cos|tan|arcsin|arccos|arctan|arctan2|exp|expm1|log|log1p|power|hypot)\(|"
                           r"[\w)\]]\s*@\s*[\w(\[]")


@pytest.mark.parametrize("module", ["tasks/oracle.py", "tasks/policies.py", "tasks/gesture.py", "tasks/carry.py",
                                    "tasks/scene.py", "trajectory.py"])
def test_the_policies_use_only_machine_independent_arithmetic(module):
    """The scripted policies' code, and the episode draws', reaches no CPU-dependent numpy call,
    even on the branches the episodes above do not take: norms, dot products and transcendentals
    go through viscera.numerics and math."""
    source = (pathlib.Path(viscera.__file__).parent / module).read_text().splitlines()
    found = [f"{module}:{number}: {line.strip()}" for number, line in enumerate(source, 1)
             if CPU_DEPENDENT.search(line.split("#")[0])]
    assert not found, "CPU-dependent arithmetic (use viscera.numerics or math):\n" + "\n".join(found)
