"""viscera.scale.batch: N states and N control sequences stepped together, bit-identical to serial stepping."""

import mujoco
import numpy as np
import pytest

import viscera
from viscera import batch
from bench_rollout import batch_inputs  # bent intestines, smooth tool controls
from viscera.tasks import scene


@pytest.fixture(scope="module")
def abdomen():
    return mujoco.MjModel.from_xml_path(str(scene.scene_file(scene.ABDOMEN)))


def test_threads_equal_serial_stepping(abdomen):
    initial, control = batch_inputs(abdomen, batch=4, steps=40, seed=3)
    reference = batch.serial_step(abdomen, initial, control)
    for threads, chunk_size in ((1, None), (2, None), (2, 1), (3, 2)):
        with batch.BatchStepper(abdomen, threads=threads) as stepper:
            result = stepper.step(initial, control, chunk_size=chunk_size)
        assert np.array_equal(result.state, reference.state), (threads, chunk_size)
        assert np.array_equal(result.sensordata, reference.sensordata), (threads, chunk_size)
    assert result.state.shape == (4, 40, stepper.state_size)
    assert result.sensordata.shape == (4, 40, abdomen.nsensordata)
    # something happened: the tools moved the intestine and loaded the force sensors
    gut = viscera.intestine(abdomen)
    data = mujoco.MjData(abdomen)
    mujoco.mj_setState(abdomen, data, initial[0], batch.FULLPHYSICS)
    before = gut.positions(data).copy()
    mujoco.mj_setState(abdomen, data, result.state[0, -1], batch.FULLPHYSICS)
    assert np.abs(gut.positions(data) - before).max() > 1e-4
    assert np.abs(result.sensordata).max() > 0.0


def test_continues_a_running_task_bit_for_bit(abdomen):
    """A batch started from live task physics (state + warm start) continues exactly as the physics does."""
    env = viscera.tasks.load("clear_area", seed=0)
    env.reset()
    spec = env.action_spec()
    action = (spec.minimum + spec.maximum) / 2 + 0.3 * (spec.maximum - spec.minimum) / 2
    for _ in range(10):
        env.step(action)
    physics = env.physics
    model = physics.model.ptr
    starts = [batch.state_of(model, physics.data.ptr)]
    warmstarts = [physics.data.qacc_warmstart.copy()]
    control = np.tile(physics.data.ctrl, (2, 15, 1))
    control[1] *= 0.5
    expected = []
    for row in control:
        data = mujoco.MjData(model)
        mujoco.mj_copyData(data, model, physics.data.ptr)
        for ctrl in row:
            data.ctrl[:] = ctrl
            mujoco.mj_step(model, data)
        expected.append(batch.state_of(model, data))
    with batch.BatchStepper(model, threads=2) as stepper:
        result = stepper.step(np.repeat(starts, 2, axis=0), control, initial_warmstart=np.repeat(warmstarts, 2, axis=0))
    assert np.array_equal(result.state[:, -1], np.array(expected))
    assert not np.array_equal(expected[0], expected[1])


@pytest.mark.parametrize("argument, mutate, message", [
    ("control", lambda s, c, w: c.__setitem__((1, 2, 0), np.nan), r"control\[1, 2, 0\] = nan: must be finite"),
    ("initial_state", lambda s, c, w: s.__setitem__((0, 5), np.inf), r"initial_state\[0, 5\] = inf"),
    ("initial_warmstart", lambda s, c, w: w.__setitem__((1, 0), -np.inf), r"initial_warmstart\[1, 0\] = -inf"),
])
def test_refuses_non_finite_inputs_by_name(abdomen, argument, mutate, message):
    initial, control = batch_inputs(abdomen, batch=2, steps=3)
    warmstart = np.zeros((2, abdomen.nv))
    mutate(initial, control, warmstart)
    with batch.BatchStepper(abdomen, threads=2) as stepper, pytest.raises(ValueError, match=message):
        stepper.step(initial, control, initial_warmstart=warmstart)


def test_refuses_wrong_shapes_by_name(abdomen):
    initial, control = batch_inputs(abdomen, batch=2, steps=3)
    with batch.BatchStepper(abdomen, threads=1) as stepper:
        with pytest.raises(ValueError, match=r"control has shape \(3, 3, 9\), expected \(2, any, 9\)"):
            stepper.step(initial, np.zeros((3, 3, abdomen.nu)))
        with pytest.raises(ValueError, match=r"initial_state has shape \(2, 7\)"):
            stepper.step(initial[:, :7], control)
        with pytest.raises(ValueError, match=r"control has no steps"):
            stepper.step(initial, control[:, :0])
        for chunk_size in (0, -1, 1.5):  # 0 divides by zero in rollout, -1 never ends
            with pytest.raises(ValueError, match=rf"chunk_size = {chunk_size}: must be None or an integer"):
                stepper.step(initial, control, chunk_size=chunk_size)
    with pytest.raises(ValueError, match="model holds 3 models for 2 batch entries"):
        batch.serial_step([abdomen] * 3, initial, control)
    with pytest.raises(RuntimeError, match="closed"):
        stepper.step(initial, control)
    with pytest.raises(ValueError, match="threads = 0"):
        batch.BatchStepper(abdomen, threads=0)
