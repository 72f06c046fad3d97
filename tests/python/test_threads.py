"""mujoco.rollout on several threads steps intestines bit for bit as serial stepping does.

The plugin keeps no mutable globals and caches nothing keyed on the first model
it saw, so threads sharing one model, and a batch of models with different
configs (NOTES: rollout hands a data a model other than the one init saw), give
exactly the serial result. Serial here means mj_setState of the same
FULLPHYSICS state and the same zero warmstart that rollout starts from, then
mj_step with the same controls.
"""

import mujoco
import numpy as np
import pytest
from mujoco import rollout

import viscera
from viscera.scale.batch import serial_step  # mj_step from each FULLPHYSICS state with a zero warmstart
from bench_rollout import batch_inputs  # bent intestines, smooth tool controls
from viscera.tasks import scene

FULLPHYSICS = mujoco.mjtState.mjSTATE_FULLPHYSICS


def positions(model, state):
    data = mujoco.MjData(model)
    mujoco.mj_setState(model, data, state, FULLPHYSICS)
    return viscera.intestine(model).positions(data).copy()


def test_cavity_scene_on_two_threads_is_bit_identical_to_serial():
    """Six perturbed abdomens, tools moving, on two threads sharing one model."""
    model = mujoco.MjModel.from_xml_path(str(scene.scene_file(scene.ABDOMEN)))
    initial, controls = batch_inputs(model, 6, 60, seed=1)
    threaded, sensors = rollout.rollout(model, [mujoco.MjData(model) for _ in range(2)], initial, controls)
    expected = serial_step(model, initial, controls).state
    np.testing.assert_array_equal(threaded, expected)
    assert np.isfinite(sensors).all() and np.abs(threaded[:, -1] - initial).max() > 1e-3  # something moved


def config_models():
    """Three models, one intestine each, differing in integrator, stiffness, friction and substeps."""
    floor = '<geom type="plane" size="2 2 .1"/><geom type="box" size=".1 .1 .05" pos=".3 0 .05" friction="0.8"/>'
    configs = [dict(integrator="rk4", substeps=2),
               dict(integrator="implicit", substeps=1, stretch_stiffness=2000.0, friction=0.5),
               dict(integrator="symplectic_euler", substeps=6, damping=2.0, self_collision=0)]
    models = []
    for config in configs:
        xml = (f'<mujoco><worldbody>{floor}</worldbody>'
               + viscera.extension_xml("gut", length=1.0, control_points=30, shape="serpentine",
                                       box=[-0.2, -0.2, 0.05, 0.2, 0.2, 0.3], **config) + "</mujoco>")
        models.append(mujoco.MjModel.from_xml_string(xml))
    return models


def test_models_of_different_configs_on_two_threads_match_serial():
    models = config_models()
    assert len({m.plugin_attr.tobytes() for m in models}) == 3
    initial = np.concatenate([batch_inputs(m, 2, 200, seed=2)[0] for m in models])
    batch_models = [m for m in models for _ in range(2)]
    controls = np.zeros((6, 200, 0))
    threaded, _ = rollout.rollout(batch_models, [mujoco.MjData(models[0]) for _ in range(2)], initial, controls)
    expected = serial_step(batch_models, initial, controls).state
    np.testing.assert_array_equal(threaded, expected)
    # the configs matter: the same start ends differently under each model
    ends = [positions(m, threaded[2 * i, -1]) for i, m in enumerate(models)]
    assert min(np.abs(ends[i] - ends[j]).max() for i in range(3) for j in range(i)) > 1e-4


@pytest.mark.parametrize("threads", [1, 2, 3])
def test_thread_count_does_not_change_results(threads):
    models = config_models()
    initial, _ = batch_inputs(models[1], 5, 80, seed=3)
    reference, _ = rollout.rollout(models[1], mujoco.MjData(models[1]), initial, nstep=80)
    threaded, _ = rollout.rollout(models[1], [mujoco.MjData(models[1]) for _ in range(threads)], initial, nstep=80,
                                  chunk_size=1)
    np.testing.assert_array_equal(threaded, reference)
