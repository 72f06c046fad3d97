"""The laparoscope a trainee steers: it starts at the episode's aim, moves no physics, follows a
tool, is recorded and replays bit for bit, and its figures join the score."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

import viscera.tasks
from viscera import assess, laparoscope, recording
from viscera.laparoscope import Laparoscope
from viscera.teleop import devices
from viscera.teleop.session import CAMERA_TOOL, Session

FULL = mujoco.mjtState.mjSTATE_FULLPHYSICS


def state(physics) -> bytes:
    model, data = physics.model.ptr, physics.data.ptr
    out = np.empty(mujoco.mj_stateSize(model, FULL))
    mujoco.mj_getState(model, data, out, FULL)
    return out.tobytes()


@pytest.mark.parametrize("task", viscera.tasks.ALL)
@pytest.mark.parametrize("optics", laparoscope.OPTICS_DEG)
def test_the_scope_starts_where_the_episode_aimed_it(task, optics):
    env = viscera.tasks.load(task, seed=11)
    env.reset()
    physics = env.physics
    camera = mujoco.mj_name2id(physics.model.ptr, mujoco.mjtObj.mjOBJ_CAMERA, "laparoscope")
    position, frame = physics.data.cam_xpos[camera].copy(), physics.data.cam_xmat[camera].copy()
    scope = Laparoscope.of(physics, optics)
    scope.apply(physics, scope.initial)
    np.testing.assert_allclose(physics.data.cam_xpos[camera], position, atol=1e-15)
    np.testing.assert_allclose(physics.data.cam_xmat[camera], frame, atol=1e-14)
    assert scope.horizon_deg(physics) == pytest.approx(0.0, abs=1e-9)
    port = physics.named.data.site_xpos["laparoscope_port"]
    assert scope.port[2] == pytest.approx(port[2])  # the shaft crosses the port's height there
    assert np.all(scope.lower <= scope.initial) and np.all(scope.initial <= scope.upper)


def test_the_optics_angle_is_between_shaft_and_view_and_roll_turns_the_horizon():
    env = viscera.tasks.load("clear_area", seed=2)
    env.reset()
    for optics in laparoscope.OPTICS_DEG:
        scope = Laparoscope.of(env.physics, optics)
        pose = scope.initial + np.array([0.0, 0.0, 0.0, 40.0])
        position, x, y, z = scope.frame(pose)
        shaft = laparoscope.shaft_direction(*pose[:2])
        view = -np.array(z)
        assert math.degrees(math.acos(float(np.dot(shaft, view)))) == pytest.approx(optics, abs=1e-9)
        assert np.allclose(position, np.array(scope.port) + pose[2] * np.array(shaft))  # the tip on the shaft
        scope.apply(env.physics, pose)
        if optics == 0.0:
            assert scope.horizon_deg(env.physics) == pytest.approx(40.0, abs=1e-6)
        else:  # a 30 degree scope turned sweeps its view around the shaft, and the horizon turns too
            assert scope.horizon_deg(env.physics) > 10.0


def test_steering_the_camera_moves_no_physics():
    still, steered = (viscera.tasks.load("grasp_lift", seed=4) for _ in range(2))
    still.reset()
    steered.reset()
    scope = Laparoscope.of(steered.physics, 30.0)
    random = np.random.RandomState(0)
    spec = still.action_spec()
    for tick in range(60):
        scope.apply(steered.physics, scope.initial + np.array([20.0, -15.0, 0.02, 90.0]) * tick / 60)
        action = random.uniform(spec.minimum, spec.maximum)
        still.step(action)
        steered.step(action)
    assert state(still.physics) == state(steered.physics)
    assert not np.allclose(still.physics.data.cam_xpos, steered.physics.data.cam_xpos)


def test_follow_keeps_the_tool_visible_through_a_scripted_episode():
    """clear_area's scripted gesture (seed 0) swings the grasper across the cavity: with the fixed
    scope it leaves the view; an assistant following it keeps it in view nearly all the time."""
    results = {}
    for follow in (False, True):
        env = viscera.tasks.load("clear_area", seed=0)
        policy = viscera.tasks.scripted_policy(env)
        step = env.reset()
        scope = Laparoscope.of(env.physics, 0.0)
        pose = scope.initial.copy()
        tracer = assess.Tracer(env)
        tracer.sample(env)
        dt = env.control_timestep()
        while not step.last():
            if follow:
                pose = scope.follow(env.physics, pose, env.physics.working_point("grasper"), dt)
                scope.apply(env.physics, pose)
            step = env.step(policy(step))
            tracer.sample(env)
        results[follow] = assess.score(tracer.trace)
    fixed, followed = (results[k]["tools"]["grasper"] for k in (False, True))
    inside_s = results[True]["time_s"]
    assert fixed["out_of_view_s"] > 1.0  # 1.96 s of the 24 s episode
    assert followed["out_of_view_s"] < 0.05 * inside_s
    assert followed["centred_s"] > 0.8 * inside_s > fixed["centred_s"]
    assert results[True]["camera"]["path_deg"] > 10.0 and results[False]["camera"]["path_deg"] == 0.0


class Steering(devices.Device):
    """Drives the grasper to a target and the laparoscope through a turn, in and back."""

    name = "steering"

    def targets(self, now_s: float) -> dict:
        tools = {tool.name: tool for tool in self.tools}
        scope, grasper = tools[CAMERA_TOOL], tools["grasper"]
        camera = scope.initial + np.array([8.0, -6.0, 0.015, 35.0, 0.0])
        return {CAMERA_TOOL: camera, "grasper": grasper.initial + np.array([5.0, 5.0, 0.02, 0.0, 0.0])}


def test_a_steered_session_records_its_camera_and_replays_bit_for_bit(tmp_path):
    session = Session("grasp_lift", seed=6, device=Steering(), time_limit_s=1.5, optics_deg=30.0)
    assert [tool.name for tool in session.device.tools] == ["grasper", CAMERA_TOOL]
    while session.ended() is None and session.data.time < 1.2:
        session.tick()
    result = session.result("duration")
    made = result.recording
    assert made.camera.shape == (made.steps, 4) and made.optics_deg == 30.0
    start = made.camera[0] - session.scope.initial  # the first tick's step at the scope's speeds
    np.testing.assert_allclose(np.abs(start), laparoscope.SPEED * session.control_timestep_s)
    assert made.camera[-1][3] - session.scope.initial[3] == pytest.approx(35.0)
    path = tmp_path / "steered.npz"
    made.save(path)
    loaded = recording.load(path)
    np.testing.assert_array_equal(loaded.camera, made.camera)
    tracer = []

    def sample(env, time_step):
        if not tracer:
            tracer.append(assess.Tracer(env))
        tracer[0].sample(env)

    replayed = recording.replay(loaded, on_step=sample)
    assert replayed.matches(loaded)
    assert assess.score(tracer[0].trace) == result.score  # what the camera saw, the horizon: the same
    assert result.score["camera"]["horizon_off_s"] > 0.0 and result.score["camera"]["travel_m"] > 0.01
    camera = replayed.env.physics.data.cam_xpos[session.scope.camera]
    np.testing.assert_array_equal(camera, session.physics.data.cam_xpos[session.scope.camera])


def test_follow_mode_centres_the_active_tool_and_fixed_mode_leaves_the_aim():
    class Still(devices.Device):
        name = "still"

        def targets(self, now_s):
            grasper = self.tools[0]
            return {"grasper": grasper.initial + np.array([12.0, -12.0, 0.03, 0.0, 0.0])}

    follow = Session("grasp_lift", seed=6, device=Still(), camera="follow", record=False)
    fixed = Session("grasp_lift", seed=6, device=Still(), camera="fixed", record=False)
    assert [t.name for t in follow.device.tools] == ["grasper"] and fixed.scope is None
    for _ in range(150):
        follow.tick()
        fixed.tick()
    tip = follow.physics.working_point("grasper")
    where = follow.scope.image_point(follow.physics, tip)
    assert max(abs(where[0]), abs(where[1])) < 0.05
    assert state(follow.physics) == state(fixed.physics)  # the same tools, the same physics


def test_a_bad_camera_mode_or_optics_is_refused():
    with pytest.raises(ValueError, match="camera = 'wobble'"):
        Session("grasp_lift", seed=0, device=None, camera="wobble", record=False)
    env = viscera.tasks.load("grasp_lift", seed=0)
    env.reset()
    with pytest.raises(ValueError, match="optics = 45"):
        Laparoscope.of(env.physics, 45)


def test_a_dataset_from_a_steered_recording_sees_what_the_camera_saw():
    """dataset --policy recordings --pixels: the images of a recording with a camera track are the
    steered camera's (the first, before any tick, the aimed one's); the states are the same but
    for the camera's pose, observed with the pixels (its last 6 entries), which follows the steering."""
    from viscera.datasets import episodes
    from viscera.gymnasium_env import TaskEnv
    made = recording.record("grasp_lift", seed=2, policy="random", time_limit_s=0.1)

    def environment():
        return TaskEnv(**episodes.env_kwargs("grasp_lift", "abdomen", True, (48, 48),
                                             control_timestep_s=made.control_timestep_s,
                                             time_limit_s=made.time_limit_s))

    plain = episodes.run(environment(), made.seed, made.policy, made.actions)
    env = environment()
    env.reset(seed=made.seed)
    turned = Laparoscope.of(env.dm_env.physics, 30.0).initial + np.array([0.0, 0.0, 0.0, 45.0])
    steered = episodes.run(env, made.seed, made.policy, made.actions, camera=np.tile(turned, (made.steps, 1)),
                           optics_deg=30.0)
    assert plain.state_names[-6:] == [f"camera_pose[{i}]" for i in range(6)]
    np.testing.assert_array_equal(plain.state[:, :-6], steered.state[:, :-6])
    np.testing.assert_array_equal(plain.state[0, -6:], steered.state[0, -6:])
    assert np.dot(plain.state[-1, -3:], steered.state[-1, -3:]) < np.cos(np.radians(5.0))  # it looks elsewhere
    pixels = [k for k in plain.images if "pixels" in k or "rgb" in k][0]
    np.testing.assert_array_equal(plain.images[pixels][0], steered.images[pixels][0])
    assert np.abs(plain.images[pixels][-1].astype(int) - steered.images[pixels][-1].astype(int)).mean() > 5.0
