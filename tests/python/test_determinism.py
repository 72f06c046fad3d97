"""The same scene and actions give bit-identical states: across processes and across reset.

The trajectory's fingerprint is a SHA-256 of the full physics state (time,
qpos, qvel, actuator state, plugin state: the intestine's positions, velocities,
counters, wrenches, friction and grasp state) after every control step of the
cavity task, under random actions that move both tools and work the jaws.
"""

import os
import subprocess
import sys

import mujoco
import numpy as np

import viscera.tasks

RUN = """
import hashlib, mujoco, numpy as np, viscera.tasks
env = viscera.tasks.load("clear_area", seed=5, time_limit=2.0, end_on_success=False)
spec = env.action_spec()
actions = np.random.default_rng(11).uniform(spec.minimum, spec.maximum, (60, spec.shape[0]))
digest = hashlib.sha256()
env.reset()
physics = env.physics
size = mujoco.mj_stateSize(physics.model.ptr, mujoco.mjtState.mjSTATE_FULLPHYSICS)
state = np.empty(size)
for action in actions:
    env.step(action)
    mujoco.mj_getState(physics.model.ptr, physics.data.ptr, state, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    digest.update(state.tobytes())
print(digest.hexdigest())
"""


def fingerprint_here() -> str:
    namespace = {}
    exec(RUN.replace("print(digest.hexdigest())", "result = digest.hexdigest()"), namespace)
    return namespace["result"]


def test_identical_across_processes():
    """Two fresh interpreters (different hash seeds, one with one BLAS thread) and this one agree."""
    digests = []
    for hash_seed, threads in (("1", "1"), ("2", "4")):
        env = dict(os.environ, PYTHONHASHSEED=hash_seed, OMP_NUM_THREADS=threads, OPENBLAS_NUM_THREADS=threads,
                   TQDM_DISABLE="1")
        result = subprocess.run([sys.executable, "-c", RUN], capture_output=True, text=True, env=env, timeout=600)
        assert result.returncode == 0, result.stderr[-3000:]
        digests.append(result.stdout.split()[-1])
    digests.append(fingerprint_here())
    assert len(set(digests)) == 1, digests


def test_identical_across_reset():
    """An episode, a reset with the same seed, the same actions: every state equal bit for bit to
    the first episode's (the episode is drawn again: bowel, tissue, tilt, target)."""
    env = viscera.tasks.load("clear_area", seed=5, time_limit=2.0, end_on_success=False)
    spec = env.action_spec()
    actions = np.random.default_rng(12).uniform(spec.minimum, spec.maximum, (40, spec.shape[0]))
    kind = mujoco.mjtState.mjSTATE_FULLPHYSICS
    episodes = []
    for _ in range(3):
        viscera.tasks.reseed(env, 5)
        env.reset()
        model = env.physics.model.ptr  # each reset builds the episode's model
        states = np.empty((len(actions), mujoco.mj_stateSize(model, kind)))
        for i, action in enumerate(actions):
            env.step(action)
            mujoco.mj_getState(model, env.physics.data.ptr, states[i], kind)
        episodes.append(states)
    assert np.abs(episodes[0][-1] - episodes[0][0]).max() > 1e-3  # the tools moved the scene
    np.testing.assert_array_equal(episodes[1], episodes[0])
    np.testing.assert_array_equal(episodes[2], episodes[0])
