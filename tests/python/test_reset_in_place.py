"""Episodes set in place: a reset rewrites the compiled model's config keys and gravity instead of
compiling the episode's MJCF, and must give the very physics that compiling it gives."""

import mujoco
import numpy as np
import pytest

import viscera
import viscera.tasks

FULL = mujoco.mjtState.mjSTATE_FULLPHYSICS


def state_of(model, data) -> np.ndarray:
    state = np.empty(mujoco.mj_stateSize(model, FULL))
    mujoco.mj_getState(model, data, state, FULL)
    return state


@pytest.mark.parametrize("task, scene", [("grasp_lift", "abdomen"), ("clear_area", "abdomen"),
                                         ("run_the_bowel", "anatomical")])
def test_an_episode_set_in_place_steps_as_its_compiled_mjcf(task, scene):
    """The third episode of an environment (two others set before it in the same model) and a
    model compiled from that episode's own MJCF: the same config text, and 100 steps from the same
    state under the same controls give the same state, bit for bit."""
    env = viscera.tasks.load(task, seed=7, scene=scene)
    for _ in range(3):
        env.reset()
    physics, episode_task = env.physics, env.task
    model, data = physics.model.ptr, physics.data.ptr
    compiled = mujoco.MjModel.from_xml_string(episode_task.scene_xml(episode_task.episode))
    assert bytes(compiled.plugin_attr) == bytes(model.plugin_attr)
    np.testing.assert_array_equal(compiled.opt.gravity, model.opt.gravity)
    # what the tasks set in place in both ways of building: the target's place, the camera's aim
    compiled.site_pos[:] = model.site_pos
    compiled.cam_quat[:] = model.cam_quat
    compiled.light_dir[:] = model.light_dir
    fresh = mujoco.MjData(compiled)
    mujoco.mj_setState(compiled, fresh, state_of(model, data), FULL)
    random = np.random.RandomState(0)
    low, high = model.actuator_ctrlrange[:, 0], model.actuator_ctrlrange[:, 1]
    for _ in range(100):
        data.ctrl[:] = fresh.ctrl[:] = random.uniform(low, high)
        mujoco.mj_step(model, data)
        mujoco.mj_step(compiled, fresh)
    assert state_of(model, data).tobytes() == state_of(compiled, fresh).tobytes()


def test_a_reset_starts_from_the_banks_settled_shape_at_rest():
    env = viscera.tasks.load("clear_area", seed=3)
    env.reset()
    gut, data = env.physics.intestine(), env.physics.data.ptr
    np.testing.assert_array_equal(gut.positions(data), env.task.episode.control_points)
    assert not gut.velocities(data).any()
    assert data.time == 0.0
    np.testing.assert_array_equal(env.physics.model.opt.gravity, env.task.episode.gravity)
    assert gut.mass == pytest.approx(env.task.episode.mass, rel=1e-15)


def test_episodes_do_not_depend_on_what_ran_before():
    """The third episode of seed 5 played after two others, and the same draw in an environment
    whose first episode it is: the same start and the same 20 steps, bit for bit."""
    second = viscera.tasks.load("grasp_lift", seed=5)
    second.reset()
    second.reset()
    fresh = viscera.tasks.load("grasp_lift", seed=5)
    fresh.task.random.set_state(second.task.random.get_state())
    second.reset()
    fresh.reset()
    for _ in range(20):
        action = np.zeros(second.action_spec().shape)
        second.step(action)
        fresh.step(action)
    model = second.physics.model.ptr
    assert state_of(model, second.physics.data.ptr).tobytes() == state_of(fresh.physics.model.ptr,
                                                                          fresh.physics.data.ptr).tobytes()


def test_reconfigure_refuses_a_value_of_another_width_and_keeps_the_model():
    env = viscera.tasks.load("grasp_lift", seed=1)
    env.reset()
    model, data = env.physics.model.ptr, env.physics.data.ptr
    before = bytes(model.plugin_attr)
    with pytest.raises(ValueError, match=r"config key 'mass': the new value has 3 characters"):
        viscera.reconfigure(model, data, 0, {"mass": "1.5"})
    with pytest.raises(ValueError, match=r"unknown config key 'masss'.*did you mean 'mass'"):
        viscera.reconfigure(model, data, 0, {"masss": "1"})
    with pytest.raises(ValueError, match=r"mass"):  # the plugin's own check of the value, as at load
        viscera.reconfigure(model, data, 0, {"mass": viscera.fixed_width_numbers([-1.0])})
    assert bytes(model.plugin_attr) == before
    env.step(np.zeros(env.action_spec().shape))  # the kept caches still step
