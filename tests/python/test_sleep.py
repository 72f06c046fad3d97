"""Sleeping through MuJoCo (the core's own cases are in tests/c/test_sleep.c): the shipped cavity
at rest falls asleep and stays exactly put; a change of gravity, a reset or a written state wakes
it; a paddle pressing it wakes it, even a mocap one; copies of a sleeping mjData step alike;
and the config refuses sleeping where it cannot work, naming the attribute and the value."""

import copy
import pickle

import mujoco
import numpy as np
import pytest

import viscera
from viscera.tasks import scene

from conftest import compile_scene


def cavity() -> tuple[mujoco.MjModel, mujoco.MjData, viscera.Intestine]:
    model = mujoco.MjModel.from_xml_path(str(scene.scene_file(scene.ABDOMEN)))
    return model, mujoco.MjData(model), viscera.intestine(model)


def steps(model, data, count: int) -> None:
    for _ in range(count):
        mujoco.mj_step(model, data)


def test_the_resting_cavity_falls_asleep_and_stays_exactly_put():
    model, data, gut = cavity()
    assert gut.sleeps and gut.sleep_time_s == pytest.approx(0.25)
    steps(model, data, 300)  # 0.6 s: its settled bowel rests for sleep_time, then sleeps
    assert gut.asleep(data).all()
    held = gut.positions(data).copy()
    steps(model, data, 200)
    np.testing.assert_array_equal(gut.positions(data), held)
    assert not gut.velocities(data).any()


def test_gravity_a_reset_and_a_written_state_wake_it():
    model, data, gut = cavity()
    steps(model, data, 300)
    assert gut.asleep(data).all()
    model.opt.gravity[0] = 1.0  # tilted: every point must feel it
    mujoco.mj_step(model, data)
    assert not gut.asleep(data).any()
    steps(model, data, 25)
    assert np.abs(gut.velocities(data)[:, 0]).max() > 0.01  # and it slides
    model.opt.gravity[0] = 0.0
    mujoco.mj_resetData(model, data)
    assert not gut.asleep(data).any()
    steps(model, data, 300)
    assert gut.asleep(data).all()
    gut.positions(data)[:] += [0.0, 0.0, 0.01]  # written 1 cm up: awake there, and it falls back
    mujoco.mj_step(model, data)
    assert not gut.asleep(data).any()
    assert gut.velocities(data)[:, 2].min() < 0.0


def press_with_a_mocap_paddle(sleep: int) -> tuple[np.ndarray, float]:
    """A 1 m tube asleep on the floor; a mocap paddle (moved by setting mocap_pos: its geom has
    no velocity) comes down on its middle at 5 cm/s until its underside is 5 mm into the tube,
    and holds there 1 s. Returns the final control points and the deepest sphere-paddle contact
    (m)."""
    floor = '<geom name="floor" type="plane" size="2 2 0.1"/>'
    paddle = '<body name="paddle" mocap="true" pos="0.5 0 0.1"><geom name="paddle" type="box" size="0.04 0.04 0.005"/></body>'
    model, data, gut = compile_scene(floor + paddle, length=1.0, control_points=30, radius=0.0125, shape="line",
                                     start=[0.0, 0.0, 0.0125], direction=[1.0, 0.0, 0.0], sleep=sleep)
    steps(model, data, 200)
    assert gut.asleep(data).all() == bool(sleep)
    bottom, deepest = 0.025 - 0.005, 0.0  # the paddle's underside, finally 5 mm into the tube's top
    for step in range(1000):
        underside = max(0.095 - 0.05 * 0.002 * (step + 1), bottom)
        data.mocap_pos[0, 2] = underside + 0.005
        mujoco.mj_step(model, data)
        axis = gut.positions(data)
        near = np.abs(axis[:, 0] - 0.5) < 0.04
        deepest = max(deepest, float((0.0125 - (underside - axis[near, 2])).max()))
    return gut.positions(data).copy(), deepest


def test_a_paddle_pressing_the_sleeping_bowel_wakes_it():
    """Asleep or not, the tube gives way under the paddle the same: a geom pressing a sleeping
    sphere wakes it, even a mocap body's, which moves without a velocity."""
    asleep, deepest_asleep = press_with_a_mocap_paddle(1)
    awake, deepest_awake = press_with_a_mocap_paddle(0)
    assert deepest_awake < 0.0125  # the tube moved out from under the paddle's edge or flattened, not through it
    assert deepest_asleep == pytest.approx(deepest_awake, abs=0.0015)
    assert np.abs(asleep - awake).max() < 0.002


def test_copies_and_pickles_of_a_sleeping_bowel_step_alike():
    model, data, gut = cavity()
    steps(model, data, 200)  # partly asleep
    copies = [copy.deepcopy(data), pickle.loads(pickle.dumps(data))]
    model.opt.gravity[1] = 0.5  # a change every copy sees: they wake and move alike
    for d in [data] + copies:
        steps(model, d, 150)
    for other in copies:
        np.testing.assert_array_equal(other.plugin_state, data.plugin_state)


@pytest.mark.parametrize("config, message", [
    (dict(sleep=1, integrator="implicit"), "attribute 'sleep' = '1' needs 'mass_matrix' = 'lumped'"),
    (dict(sleep=1, mass_matrix="consistent"), "'mass_matrix' = 'consistent'"),
    (dict(sleep=2), "attribute 'sleep' = '2' must be at most 1"),
    (dict(sleep_time=0), "attribute 'sleep_time' = '0' must be positive"),
    (dict(sleep_speed="fast"), "attribute 'sleep_speed' = 'fast' is not a finite number"),
])
def test_bad_sleep_config_is_refused_at_load(config, message):
    with pytest.raises(ValueError, match=message):
        compile_scene(length=1.0, control_points=30, **config)


def test_sleep_is_off_unless_a_scene_turns_it_on():
    """Off by default: it stops what creeps slower than sleep_speed, which a beam settling or
    vibrating does; the shipped cavity, where it is measured, turns it on, and the tasks with it."""
    assert not compile_scene(length=1.0, control_points=30)[2].sleeps
    assert compile_scene(length=1.0, control_points=30, sleep=1)[2].sleeps
    assert cavity()[2].sleeps
    import viscera.tasks
    env = viscera.tasks.load("grasp_lift", seed=0)
    assert viscera.intestine(env.physics.model.ptr).sleeps
