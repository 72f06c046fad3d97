"""dm_control tasks, in the manner of dm_control's suite_test: specs, determinism, robustness."""

import subprocess
import sys

import mujoco
import numpy as np
import pytest
from mujoco import rollout

import viscera.tasks
from viscera.tasks.gesture import ClearingGesture


def random_actions(env, seed, count):
    spec = env.action_spec()
    rng = np.random.RandomState(seed)
    return [rng.uniform(spec.minimum, spec.maximum) for _ in range(count)]


def test_registry():
    assert viscera.tasks.ALL == tuple(viscera.task_registry.TASKS) and "clear_area" in viscera.tasks.ALL
    with pytest.raises(KeyError, match="clear_area"):
        viscera.tasks.load("clear_the_area")


@pytest.mark.parametrize("name", viscera.tasks.ALL)
def test_specs_and_rewards_conform(name):
    env = viscera.tasks.load(name, seed=0, time_limit=1.0)
    step = env.reset()
    specs = env.observation_spec()
    for action in random_actions(env, 1, 20):
        for key, spec in specs.items():
            spec.validate(step.observation[key])  # shape and dtype as declared
        step = env.step(action)
        assert 0.0 <= step.reward <= 1.0
        assert all(np.isfinite(value).all() for value in step.observation.values())


@pytest.mark.parametrize("name", viscera.tasks.ALL)
def test_deterministic_per_seed_and_reset(name):
    runs = []
    for _ in range(2):
        env = viscera.tasks.load(name, seed=3, time_limit=1.0)
        first = env.reset().observation
        for action in random_actions(env, 7, 25):
            step = env.step(action)
        runs.append((first, step.observation))
        again = env.reset().observation  # a second reset restores the same start
        for key in first:
            np.testing.assert_array_equal(again[key], first[key])
    for key in runs[0][1]:
        np.testing.assert_array_equal(runs[0][1][key], runs[1][1][key])


def test_random_actions_do_not_break_it():
    """A random-action episode: no NaN, no divergence, the intestine stays in the cavity."""
    env = viscera.tasks.load("clear_area", seed=1, time_limit=2.0, end_on_success=False)  # all 2 s
    env.reset()
    for action in random_actions(env, 2, 100):
        step = env.step(action)
    gut = env.physics.intestine()
    axis = env.physics.axis_points(1000)
    assert gut.divergence_count(env.physics.data.ptr) == 0
    assert (np.abs(axis[:, 0]) < 0.15).all() and (np.abs(axis[:, 1]) < 0.125).all()
    assert axis[:, 2].min() > 0.0 and axis[:, 2].max() < 0.15
    assert step.last()  # the time limit ends the episode


def test_the_scripted_gesture_clears_the_target_and_again_after_a_reset():
    """The clearing gesture as the task's policy: at least 0.8 of the target uncovered within
    20 s where doing nothing leaves it covered; a second reset restores the start exactly."""
    env = viscera.tasks.load("clear_area", seed=0, time_limit=20.0)
    policy = ClearingGesture(env)
    results = []
    for _ in range(2):
        step = env.reset()
        while not step.last():
            step = env.step(policy(step))
        results.append((step.reward, env.physics.data.time, policy.cycles))
    reward, seconds, cycles = results[0]
    assert reward >= 0.8 and seconds <= 20.0 + 1e-9 and cycles >= 1
    assert results[1] == results[0]


def test_gesture_command_prints_the_uncovered_fraction_last():
    """`python -m viscera.tasks.gesture` plays the whole gesture (withdrawal included)."""
    done = subprocess.run([sys.executable, "-m", "viscera.tasks.gesture", "--quiet"], capture_output=True, text=True,
                          timeout=600)
    assert done.returncode == 0, done.stderr
    last = done.stdout.strip().splitlines()[-1]
    assert last.startswith("uncovered: ")
    assert float(last.split(":")[1]) >= 0.8


def test_the_environment_steps_under_mujoco_rollout():
    """The task's model and state under mujoco.rollout on two threads, three control
    sequences: each matches stepping one MjData alone."""
    env = viscera.tasks.load("clear_area", seed=0)
    env.reset()
    model, data = env.physics.model.ptr, env.physics.data.ptr
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    initial = np.empty(mujoco.mj_stateSize(model, spec))
    mujoco.mj_getState(model, data, initial, spec)
    controls = np.stack([np.tile(action, (150, 1)) for action in random_actions(env, 4, 3)])
    states, _ = rollout.rollout(model, [mujoco.MjData(model) for _ in range(2)], np.tile(initial, (3, 1)), controls)
    for i in range(3):
        alone = mujoco.MjData(model)
        mujoco.mj_setState(model, alone, initial, spec)
        for t in range(150):
            alone.ctrl[:] = controls[i, t]
            mujoco.mj_step(model, alone)
        expected = np.empty_like(initial)
        mujoco.mj_getState(model, alone, expected, spec)
        np.testing.assert_allclose(states[i, -1], expected, rtol=0, atol=1e-9)


def test_doing_nothing_leaves_the_area_covered():
    env = viscera.tasks.load("clear_area", seed=0, time_limit=2.0)
    env.reset()
    zeros = np.zeros(env.action_spec().shape)
    while True:
        step = env.step(zeros)
        if step.last():
            break
    assert step.reward < 0.2


def test_environments_do_not_share_state():
    """Two environments stepped in turn behave as each alone."""
    alone = viscera.tasks.load("clear_area", seed=5, time_limit=1.0)
    alone.reset()
    actions = random_actions(alone, 9, 15)
    for action in actions:
        expected = alone.step(action).observation
    a = viscera.tasks.load("clear_area", seed=5, time_limit=1.0)
    b = viscera.tasks.load("clear_area", seed=6, time_limit=1.0)
    a.reset()
    b.reset()
    for action in actions:
        got = a.step(action).observation
        b.step(-action)
    for key in expected:
        np.testing.assert_array_equal(got[key], expected[key])
