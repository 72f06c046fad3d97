"""dm_control tasks, in the manner of dm_control's suite_test: specs, determinism, robustness."""

import numpy as np
import pytest

import viscera.tasks


def random_actions(env, seed, count):
    spec = env.action_spec()
    rng = np.random.RandomState(seed)
    return [rng.uniform(spec.minimum, spec.maximum) for _ in range(count)]


def test_registry():
    assert viscera.tasks.ALL == ("clear_area",)
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
    env = viscera.tasks.load("clear_area", seed=1, time_limit=2.0)
    env.reset()
    for action in random_actions(env, 2, 100):
        step = env.step(action)
    gut = env.physics.intestine()
    axis = env.physics.axis_points(1000)
    assert gut.divergence_count(env.physics.data.ptr) == 0
    assert (np.abs(axis[:, 0]) < 0.15).all() and (np.abs(axis[:, 1]) < 0.125).all()
    assert axis[:, 2].min() > 0.0 and axis[:, 2].max() < 0.15
    assert step.last()  # the time limit ends the episode


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
