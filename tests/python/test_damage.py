"""The wall's damage (docs/model.md#damage): kept in the plugin's state, bruised by the force-time
product of a held pinch, perforated at the perforation pinch, drawn on the skin (MuJoCo's
renderer and meshcat's vertex colours), labelled in segmentation, scored, and ending a task's
episode as a failure."""

import pathlib
import sys

import mujoco
import numpy as np
import pytest

import viscera
from viscera import assess

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[2] / "python" / "tools"))
from validation.organ import grasp_slip  # noqa: E402

STEP_S = grasp_slip.TIMESTEP_S


def hold(pinch_n: float, seconds: float, **keys):
    model, data, gut = grasp_slip.grasped_segment(pinch_n, **keys)
    steps = int(round(seconds / STEP_S))
    held = 0
    for _ in range(steps):
        mujoco.mj_step(model, data)
        held += gut.grasps(data)[0].holding
    return model, data, gut, held * STEP_S


def test_the_plugins_limits_are_the_scores():
    docs = viscera.attribute_docs()
    assert float(docs["damage_perforation_pinch"]["default"]) == assess.PERFORATION_PINCH_N
    assert float(docs["damage_force_time"]["default"]) == assess.FORCE_TIME_PRODUCT_LIMIT_NS


def test_a_held_pinch_bruises_by_its_force_time_product_and_does_not_perforate():
    model, data, gut, held_s = hold(6.0, 2.0)
    damage = gut.damage(data)
    assert held_s > 1.8  # the jaw takes about 0.14 s to close
    # every step held adds pinch x step / 300 N s, shared between the two points around the hold
    assert damage[:, 0].sum() == pytest.approx(6.0 * held_s / assess.FORCE_TIME_PRODUCT_LIMIT_NS, rel=1e-6)
    assert damage[-1, 0] > 0.0 and damage[:-2, 0].max() == 0.0  # at the held end only
    assert not damage[:, 1].any()
    worst, where, torn = assess.damage_summary(gut, data)
    assert worst == damage[:, 0].max() and where == pytest.approx(gut.rest_length) and torn == []


def test_a_pinch_past_the_limit_perforates_where_it_holds():
    model, data, gut, _ = hold(12.0, 0.1)
    damage = gut.damage(data)
    assert damage[-1, 1] == 1.0 and damage[-1, 0] == 1.0 and damage[:-1, 1].sum() == 0.0
    assert assess.damage_summary(gut, data)[2] == [pytest.approx(gut.rest_length)]
    # a higher limit from the config: the same pinch bruises only
    model, data, gut, _ = hold(12.0, 0.1, damage_perforation_pinch=15)
    assert not gut.damage(data)[:, 1].any()


def test_damage_is_state_copied_and_healed_by_a_reset():
    model, data, gut, _ = hold(6.0, 0.5)
    copy = mujoco.MjData(model)
    mujoco.mj_copyData(copy, model, data)
    np.testing.assert_array_equal(gut.damage(copy), gut.damage(data))
    for d in (data, copy):
        mujoco.mj_step(model, d)
    np.testing.assert_array_equal(gut.damage(copy), gut.damage(data))
    mujoco.mj_resetData(model, data)
    assert not gut.damage(data).any()


def test_the_renderer_draws_bruising_and_segmentation_labels_the_damaged_wall():
    from viscera.pixels import LABELS, Camera
    from viscera.viewer import skin_colours

    model, data, gut, _ = hold(12.0, 0.1)  # the held end perforated
    bruise_rgb, torn_rgb = viscera.damage_colours()
    scene = mujoco.MjvScene(model, maxgeom=2000)
    mujoco.mjv_updateScene(model, data, mujoco.MjvOption(), None, mujoco.MjvCamera(), mujoco.mjtCatBit.mjCAT_ALL,
                           scene)
    capsules = [scene.geoms[i] for i in range(scene.ngeom) if scene.geoms[i].objtype == mujoco.mjtObj.mjOBJ_PLUGIN]
    last, first = capsules[-1], capsules[0]
    np.testing.assert_allclose(last.rgba[:3], torn_rgb, atol=1e-6)
    assert last.dataid == 1 and first.dataid == -1
    healthy = np.array(first.rgba[:3])
    assert not np.allclose(healthy, torn_rgb)
    colours = skin_colours(gut, len(viscera.skin(model, data, gut.instance)[0]), gut.damage(data))
    np.testing.assert_allclose(colours[0], healthy, atol=1e-6)  # the first ring: whole


def test_a_perforation_ends_the_episode_as_a_failure_and_is_scored_and_seen():
    from viscera import tasks
    from viscera.pixels import LABELS, Camera

    env = tasks.load("grasp_lift", seed=3)
    time_step = env.reset()
    physics = env.physics
    tracer = assess.Tracer(env)
    tracer.sample(env)
    camera = Camera(96, 96)
    assert not (camera.render(physics)["segmentation"] == LABELS["damaged"]).any()
    damage = physics.intestine().damage(physics.data.ptr)
    damage[10:13] = 1.0  # a perforation, written into the state as a pinch would
    damage[:, 0] = np.maximum(damage[:, 0], 0.3)
    damage[:] = np.where(np.arange(len(damage))[:, None] < 10, damage, 1.0)  # and the rest of the bowel from 10 on
    labels = camera.render(physics)["segmentation"]
    assert (labels == LABELS["damaged"]).any()
    time_step = env.step(np.array(physics.data.ctrl))  # the tools held where they are
    assert time_step.last() and time_step.discount == 0.0 and env.task.failed
    tracer.sample(env)
    score = assess.score(tracer.trace)
    spacing = physics.intestine().rest_length / (len(damage) - 1)
    assert score["tissue"]["perforations"] == 1 and score["tissue"]["damage_max"] == 1.0
    assert score["tissue"]["perforations_where_m"][0] == pytest.approx(0.5 * (10 + len(damage) - 1) * spacing)
    assert any("perforations 1" in line for line in assess.summary_lines(score))


def test_a_grasper_strengthened_beyond_perforation_perforates_and_the_episode_fails():
    """The shipped grasper closes with 6.4 N at most; three times its jaw's gain squeezes 19 N, past
    the 10.3 N that perforates: the scripted grasp perforates the band where it holds, the episode
    ends there as a failure, and the score says so."""
    from viscera import tasks

    env = tasks.load("grasp_lift", seed=1000)
    time_step = env.reset()
    physics = env.physics
    jaw = physics.model.actuator("grasper_jaw").id
    physics.model.actuator_gainprm[jaw, 0] *= 3.0
    physics.model.actuator_biasprm[jaw, 1] *= 3.0
    policy = env.task.POLICY(env)
    tracer = assess.Tracer(env)
    tracer.sample(env)
    held_at = None
    while not time_step.last():
        time_step = env.step(policy(time_step))
        tracer.sample(env)
        held = physics.held_abscissae()[0]
        held_at = held if held >= 0 else held_at
    assert physics.perforated() and env.task.failed and time_step.discount == 0.0
    assert not env.task.success(physics)
    score = assess.score(tracer.trace)
    assert score["tissue"]["perforations"] == 1 and score["tissue"]["peak_pinch_n"] > assess.PERFORATION_PINCH_N
    spacing = physics.intestine().rest_length / (physics.intestine().control_count - 1)
    assert abs(score["tissue"]["perforations_where_m"][0] - held_at) <= spacing  # where the jaws held
    assert not score["success"]
