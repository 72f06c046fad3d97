"""All persistent state lives in plugin_state: save, restore, reset, copy, rollout."""

import mujoco
import numpy as np
from mujoco import rollout

import viscera
from conftest import compile_scene, scene_xml

# everything that determines the next step, solver warmstart included (bit-exact replay)
FULL = mujoco.mjtState.mjSTATE_INTEGRATION


def step(model, data, count):
    for _ in range(count):
        mujoco.mj_step(model, data)


def test_state_layout_is_positions_then_velocities(falling_line):
    model, data, gut = falling_line
    step(model, data, 50)
    state = data.plugin_state[model.plugin_stateadr[0]:]
    n = gut.control_count
    np.testing.assert_array_equal(state[:3 * n].reshape(n, 3), gut.positions(data))
    np.testing.assert_array_equal(state[3 * n:6 * n].reshape(n, 3), gut.velocities(data))
    # velocities are the time derivative of positions (central difference over one step)
    before = gut.positions(data).copy()
    step(model, data, 1)
    mid_velocity = gut.velocities(data).copy()
    step(model, data, 1)
    estimate = (gut.positions(data) - before) / (2 * model.opt.timestep)
    np.testing.assert_allclose(estimate, mid_velocity, atol=1e-3 * max(1.0, np.abs(mid_velocity).max()))


def test_get_set_state_round_trip_replays_exactly(falling_line):
    model, data, gut = falling_line
    step(model, data, 100)
    saved = np.empty(mujoco.mj_stateSize(model, FULL))
    mujoco.mj_getState(model, data, saved, FULL)
    step(model, data, 100)
    first = (gut.positions(data).copy(), data.qpos.copy())
    mujoco.mj_setState(model, data, saved, FULL)
    step(model, data, 100)
    np.testing.assert_array_equal(gut.positions(data), first[0])
    np.testing.assert_array_equal(data.qpos, first[1])


def test_reset_writes_the_initial_shape(falling_line):
    model, data, gut = falling_line
    initial = gut.positions(data).copy()
    np.testing.assert_allclose(initial[0], [0.0, 0.0, 0.3])
    step(model, data, 100)
    assert not np.allclose(gut.positions(data), initial)
    mujoco.mj_resetData(model, data)
    np.testing.assert_array_equal(gut.positions(data), initial)
    assert not gut.velocities(data).any()
    assert gut.divergence_count(data) == 0


def test_copy_data_continues_identically(falling_line):
    model, data, gut = falling_line
    step(model, data, 80)
    other = mujoco.MjData(model)
    mujoco.mj_copyData(other, model, data)
    step(model, data, 80)
    step(model, other, 80)
    np.testing.assert_array_equal(gut.positions(other), gut.positions(data))


def test_rollout_threads_match_sequential_stepping(falling_line):
    """mujoco.rollout steps four intestines on two threads; each matches sequential stepping.

    rollout takes FULLPHYSICS states (no solver warmstart), so the box contact may
    differ in the last bits; shared mutable state between threads would not.
    """
    model, data, gut = falling_line
    physics = mujoco.mjtState.mjSTATE_FULLPHYSICS
    initial = np.empty((4, mujoco.mj_stateSize(model, physics)))
    for i in range(4):
        mujoco.mj_resetData(model, data)
        gut.positions(data)[:, 2] += 0.05 * i  # four different drops
        mujoco.mj_getState(model, data, initial[i], physics)
    datas = [mujoco.MjData(model) for _ in range(2)]
    states, _ = rollout.rollout(model, datas, initial, nstep=150)
    for i in range(4):
        mujoco.mj_resetData(model, data)
        mujoco.mj_setState(model, data, initial[i], physics)
        step(model, data, 150)
        expected = np.empty(mujoco.mj_stateSize(model, physics))
        mujoco.mj_getState(model, data, expected, physics)
        np.testing.assert_allclose(states[i, -1], expected, rtol=0, atol=1e-9)


def test_dm_control_physics_state_reset_copy():
    from dm_control import mujoco as dm_mujoco
    physics = dm_mujoco.Physics.from_xml_string(scene_xml('<geom type="plane" size="2 2 .1"/>', control_points=30,
                                                          length=1, shape="line", start=[0, 0, 0.2]))
    gut = viscera.intestine(physics.model.ptr)
    initial = gut.positions(physics.data.ptr).copy()
    for _ in range(50):
        physics.step()
    state = physics.get_state()
    for _ in range(50):
        physics.step()
    later = gut.positions(physics.data.ptr).copy()
    physics.set_state(state)
    for _ in range(50):
        physics.step()
    np.testing.assert_array_equal(gut.positions(physics.data.ptr), later)
    twin = physics.copy(share_model=True)
    for _ in range(20):
        physics.step()
        twin.step()
    np.testing.assert_array_equal(gut.positions(twin.data.ptr), gut.positions(physics.data.ptr))
    physics.reset()
    np.testing.assert_array_equal(gut.positions(physics.data.ptr), initial)


def test_two_instances_are_independent():
    ext = (viscera.extension_xml("a", length=1, control_points=20, shape="line", start=[0, 0, 1])
           .replace("</plugin>\n</extension>", "") +
           '\n<instance name="b"><config key="length" value="2"/><config key="control_points" value="30"/>'
           '<config key="start" value="0 1 3"/></instance></plugin></extension>')
    model = mujoco.MjModel.from_xml_string(f"<mujoco>{ext}</mujoco>")
    data = mujoco.MjData(model)
    a, b = viscera.intestine(model, "a"), viscera.intestine(model, "b")
    assert (a.control_count, b.control_count) == (20, 30)
    step(model, data, 10)
    mujoco.mj_resetData(model, data)
    np.testing.assert_allclose(a.positions(data)[-1], [1, 0, 1])
    np.testing.assert_allclose(b.positions(data)[-1], [2, 1, 3])


def test_python_axis_interpolates_the_control_points(falling_line):
    model, data, gut = falling_line
    step(model, data, 200)
    n = gut.control_count
    on_nodes = viscera.spline_points(gut.positions(data), np.arange(n) / (n - 1))
    np.testing.assert_allclose(on_nodes, gut.positions(data), atol=1e-14)


def test_diverging_state_is_restored_flagged_and_finite(capfd, caplog):
    """Far past the stability limit: MuJoCo gets a warning, Python a count, and never a NaN."""
    model, data, gut = compile_scene(options='timestep="0.01"', stretch_stiffness=1e6, substeps=1, control_points=30,
                                     length=1, shape="line")
    gut.positions(data)[::2, 1] += 0.01  # a zigzag that the far too stiff springs blow up
    step(model, data, 20)
    assert gut.divergence_count(data) == 20
    assert np.isfinite(data.plugin_state).all()
    assert np.isfinite(data.qfrc_passive).all()
    printed = capfd.readouterr()  # MuJoCo prints warnings, or logs them once dm_control is imported
    warnings = (printed.out + printed.err + caplog.text).count("viscera.intestine: state diverged")
    assert warnings == 5  # at counts 1, 2, 4, 8, 16


def test_the_state_layout_comes_from_the_plugin_and_tiles_its_state():
    """Python reads plugin_state's blocks from C (state_layout.h): in order, back to back, their
    sizes what the config implies (3n, 3n, 1, 1, 6 per body, 8 per sphere, 6 per grasper, 8 per
    control point, 3, 2 per control point), and together exactly the instance's plugin_statenum."""
    body = ('<body name="g" pos="0 0 1"><joint name="jaw" type="hinge"/><site name="tip"/>'
            '<geom type="sphere" size="0.01" contype="0" conaffinity="0"/></body>')
    model, data, gut = compile_scene(body, length=1.0, control_points=30, grasp_sites="tip", grasp_joints="jaw")
    layout = gut.layout
    assert list(layout) == ["positions", "velocities", "divergences", "recoveries", "wrenches", "friction", "grasps",
                            "rest", "gravity", "damage"]
    sizes = {"positions": 3 * 30, "velocities": 3 * 30, "divergences": 1, "recoveries": 1,
             "wrenches": 6 * model.nbody, "friction": 8 * gut.sphere_count, "grasps": 6 * 1, "rest": 8 * 30, "gravity": 3,
             "damage": 2 * 30}
    at = 0
    for name, block in layout.items():
        assert block.start == at and block.stop - block.start == sizes[name], name
        at = block.stop
    assert at == model.plugin_statenum[0]
    mujoco.mj_step(model, data)
    state = data.plugin_state[model.plugin_stateadr[0]:model.plugin_stateadr[0] + model.plugin_statenum[0]]
    np.testing.assert_array_equal(state[layout["positions"]].reshape(-1, 3), gut.positions(data))
    assert gut.grasps(data)[0].status == "closed"  # jaw at 0 rad, 1 m above the axis: closed, holding nothing
