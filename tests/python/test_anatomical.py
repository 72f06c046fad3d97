"""The anatomical abdomen (assets/scenes/abdomen_anatomical.xml): its anatomy against the sources
its comments cite, its settled start at rest, its bank, and the tasks on it."""

import mujoco
import numpy as np
import pytest

import settle
import viscera
import viscera.tasks
from viscera.tasks import scene

from test_package import ROOT

ANATOMICAL = ROOT / "assets" / "scenes" / "abdomen_anatomical.xml"


@pytest.fixture(scope="module")
def abdomen():
    model = mujoco.MjModel.from_xml_path(str(ANATOMICAL))
    small_bowel, colon = viscera.intestines(model)
    return model, small_bowel, colon


def _distance_to_wall(centre):
    """The distance (m) from `centre` (m) to the posterior wall's surface (the function its
    heightfield samples, python/tools/posterior_wall.py), over a 1 mm grid around it."""
    u = np.linspace(-0.04, 0.04, 81)
    x, y = np.meshgrid(centre[0] + u, centre[1] + u)
    surface = np.stack([x.ravel(), y.ravel(), settle.posterior_wall.wall_height(x.ravel(), y.ravel())], axis=1)
    return float(np.min(np.linalg.norm(surface - centre, axis=1)))


def test_the_small_bowel_and_colon_are_sized_as_their_sources_say(abdomen):
    """Teitelbaum et al. 2013: 506 +- 105 cm in vivo; Cronin et al.: jejunal 24.5 mm and ileal
    18.7 mm diameters, the taper from one to the other; the colon an adult's, at least 1.4 m, its
    radius 2.5 to 3 cm; the bowel is the first instance."""
    model, small_bowel, colon = abdomen
    assert small_bowel.name.endswith("small_bowel") and colon.name.endswith("colon")
    assert small_bowel.rest_length == pytest.approx(5.06, abs=1e-9)
    assert small_bowel.radius == pytest.approx(0.0245 / 2) and small_bowel.radius_end == pytest.approx(0.0187 / 2)
    assert small_bowel.config["wall_thickness"] == "0.002"  # the springs scale as this wall's section (1.5 +- 0.5 mm)
    assert colon.rest_length >= 1.4
    assert colon.rest_length == pytest.approx(np.linalg.norm(np.diff(settle.colon_path(), axis=0), axis=1).sum(),
                                              abs=1e-4)
    assert 0.025 <= colon.radius <= 0.03 and colon.radius_end == colon.radius
    assert model.geom("posterior_wall").type[0] == mujoco.mjtGeom.mjGEOM_HFIELD  # curved, not a box
    for wall in ("left_flank", "right_flank", "diaphragm", "pelvic_brim"):
        assert model.geom(wall).type[0] == mujoco.mjtGeom.mjGEOM_CAPSULE


def test_the_mesentery_root_runs_from_upper_left_to_lower_right(abdomen):
    _, small_bowel, _ = abdomen
    start, end = np.array(small_bowel.config["mesentery_root"].split(), float).reshape(2, 3)
    assert start[0] < 0 < end[0] and start[1] > 0 > end[1]  # x: the patient's left to right; y: caudal to cranial
    data = mujoco.MjData(abdomen[0])
    points = small_bowel.positions(data)
    assert np.linalg.norm(points[0, :2] - start[:2]) < 0.01  # the duodenojejunal flexure ...
    assert np.linalg.norm(points[-1, :2] - end[:2]) < 0.01   # ... and the ileocaecal junction


def test_the_colon_frames_the_bowel_and_the_ileum_joins_the_caecum(abdomen):
    """Ascending (right, x > 0) and descending (left) colon pinned along their length, each pinned
    point resting on the posterior wall (retroperitoneal); the transverse and the sigmoid held at one
    point of each fold (settle.colon_pins), their loops free and clear of the tasks' targets; the
    small bowel's last point touching the caecum."""
    model, small_bowel, colon = abdomen
    data = mujoco.MjData(model)
    points = colon.positions(data)
    pinned = [int(i) for i in colon.config["pinned"].split()]
    assert pinned == settle.colon_pins(colon.control_count)
    pinned = sorted(i % colon.control_count for i in pinned)
    ascending = [i for i in pinned if points[i, 0] > 0.12]
    descending = [i for i in pinned if points[i, 0] < -0.12]
    assert len(ascending) >= 10 and len(descending) >= 10
    assert np.ptp(points[ascending, 1]) > 0.2 and np.ptp(points[descending, 1]) > 0.15  # along the flanks
    for i in ascending + descending:
        gap = _distance_to_wall(points[i]) - colon.radius
        assert -0.002 < gap < 0.004, (i, gap)  # on the wall, within the heightfield's facets
    free = [i for i in range(colon.control_count) if i not in pinned]
    assert len(free) >= 30  # the transverse colon's and the sigmoid's loops hang free
    # the colon's free loops stay off the tasks' target region (its surface, not only its axis)
    (x0, x1), (y0, y1) = scene.SCENES["anatomical"].target_region
    axis = colon.axis_points(data, 400)
    inside = (axis[:, 0] > x0) & (axis[:, 0] < x1) & (np.abs(axis[:, 1] - 0.5 * (y0 + y1)) < 0.5 * (y1 - y0) +
                                                      colon.radius)
    assert not inside.any(), axis[inside]
    ileum_end = small_bowel.positions(data)[-1]
    caecum = points[ascending]
    assert np.min(np.linalg.norm(caecum - ileum_end, axis=1)) < small_bowel.radius_end + colon.radius + 0.03


def test_the_shipped_abdomen_is_at_rest_without_recoveries(abdomen):
    """Each episode starts from the settled state: 1 s with the tools still moves no control point
    of either intestine by more than 2 mm, the pinned ones not at all, and nothing diverges."""
    model = abdomen[0]
    data = mujoco.MjData(model)
    guts = viscera.intestines(model)
    start = [gut.positions(data).copy() for gut in guts]
    while data.time < 1.0:
        mujoco.mj_step(model, data)
    for gut, before in zip(guts, start):
        moved = np.linalg.norm(gut.positions(data) - before, axis=1)
        assert moved.max() < 0.002, gut.name
        pinned = [int(i) for i in gut.config["pinned"].split()]
        assert np.all(moved[pinned] == 0.0)
        assert gut.recovery_count(data) == 0 and gut.divergence_count(data) == 0


def test_the_abdomen_at_rest_falls_asleep_whole(abdomen):
    """Tools still, both intestines asleep at every point within 2 s. The colon pressed by the small
    bowel's loops chatters at the penalty's frequency (micrometres, its velocity flipping each step);
    before a resting partner's chatter stopped waking what it touches, a third of the colon and a
    fifth of the small bowel never slept (docs/model.md#sleeping)."""
    model = abdomen[0]
    data = mujoco.MjData(model)
    while data.time < 2.0:
        mujoco.mj_step(model, data)
    for gut in viscera.intestines(model):
        assert np.all(gut.asleep(data)), (gut.name, np.flatnonzero(~np.asarray(gut.asleep(data), bool)))


def test_the_small_bowel_takes_one_substep_and_settles_after_a_sweep(abdomen):
    """The small bowel's stiffest elastic mode is the global length term (2265 rad/s, its springs
    1082): with that term in the kick and a pile's damping held to gamma h 0.9, leapfrog takes one
    substep per 1 ms step (docs/integrators.md). Under 4 s of the vigorous sweep nothing diverges or
    recovers, and in the 3 s of rest after it the bowel settles: most of it asleep, and what is
    awake slow. (The damping taken implicitly point by point, tried first, left the swept pile
    churning at metres a second with nothing asleep and no recovery to show it.)"""
    import bench_cavity
    model, small_bowel, _ = abdomen
    frequencies = small_bowel.stability()
    assert frequencies["substeps"] == 1
    assert frequencies["elastic_rad_s"] < 1200.0  # the springs' mode, not the length term's
    given = mujoco.MjModel.from_xml_string(scene.with_intestine_config(ANATOMICAL.read_text(), {"substeps": "2"}))
    assert viscera.intestines(given)[0].stability()["substeps"] == 2  # a given count wins
    data = mujoco.MjData(model)
    for control in bench_cavity.sweep_controls(model, 4.0):
        data.ctrl[:] = control
        mujoco.mj_step(model, data)
    data.ctrl[:] = 0.0
    while data.time < 7.0:
        mujoco.mj_step(model, data)
    for gut in viscera.intestines(model):
        assert gut.recovery_count(data) == 0 and gut.divergence_count(data) == 0, gut.name
    assert np.mean(small_bowel.asleep(data)) > 0.6
    assert np.linalg.norm(small_bowel.velocities(data), axis=1).max() < 0.05  # m/s: settled, not churning


def test_the_bank_holds_both_intestines_settled_and_their_pins(abdomen):
    model, small_bowel, colon = abdomen
    data = mujoco.MjData(model)
    bank = np.load(scene.scene_file(scene.SCENES["anatomical"].starts))
    assert bank["control_points"].shape == (24, small_bowel.control_count, 3)
    assert bank["colon_control_points"].shape == (24, colon.control_count, 3)
    pins = [int(i) for i in colon.config["pinned"].split()]
    assert np.allclose(bank["colon_control_points"][:, pins], colon.positions(data)[pins], atol=1e-6)
    assert not np.allclose(bank["control_points"][0], bank["control_points"][1])  # layouts differ


def test_the_settling_layout_lies_inside_the_colon_on_the_wall():
    cavity = settle.ANATOMICAL
    path = settle.initial_path(5.06, 0.5 * (0.01225 + 0.00935), 0, cavity)
    assert np.linalg.norm(np.diff(path, axis=0), axis=1).sum() == pytest.approx(5.06, abs=1e-8)
    assert np.all(np.abs(path[:, 0]) <= 0.1 + 1e-9)  # inside the ascending and descending colon
    floor = settle.posterior_wall.wall_height(path[:, 0], path[:, 1])
    assert np.all(path[:, 2] >= floor + 0.0108)  # on or above the wall, clear of it


def test_an_unknown_scene_names_the_choices():
    with pytest.raises(ValueError, match=r"scene = 'belly'.*'abdomen', 'anatomical'"):
        viscera.tasks.load("grasp_lift", seed=0, scene="belly")


@pytest.mark.parametrize("task", viscera.tasks.ALL)
def test_every_task_loads_on_the_anatomical_abdomen(task):
    """The episode's bowel is the small bowel, observed at 3 cm (170 points on 5.06 m), the colon
    drawn from the same start of the bank, the target patch lying on the curved wall."""
    env = viscera.tasks.load(task, seed=3, scene="anatomical")
    step = env.reset()
    physics = env.physics
    assert step.observation["intestine_axis"].shape == (3 * 170,)
    colon = viscera.intestines(physics.model.ptr)[1].positions(physics.data.ptr)
    from_bank = env.task.episode.others["colon"]
    shipped = viscera.intestines(mujoco.MjModel.from_xml_path(str(ANATOMICAL)))[1]
    shipped = shipped.positions(mujoco.MjData(shipped.model))
    moved_from_bank = np.linalg.norm(colon - from_bank, axis=1).max()
    assert moved_from_bank < 0.02  # the episode's half-second settle moves its start little ...
    assert moved_from_bank < np.linalg.norm(colon - shipped, axis=1).max()  # ... and it is the bank's, not the file's
    if env.task.HAS_TARGET:  # the patch on the wall, as posterior_wall.py's function has it
        centre = physics.target()[:3]
        half_thickness = physics.named.model.site_size["target_area"][2]
        wall = settle.posterior_wall.wall_height(centre[0], centre[1])
        assert centre[2] == pytest.approx(wall + half_thickness, abs=0.0015)
    for _ in range(5):
        step = env.step(np.zeros(env.action_spec().shape))
    assert all(np.isfinite(v).all() for v in step.observation.values())


def test_the_scripted_grasp_lifts_the_band_on_the_anatomical_abdomen():
    env = viscera.tasks.load("grasp_lift", seed=1000, scene="anatomical")
    policy = viscera.tasks.scripted_policy(env)
    step = env.reset()
    while not step.last():
        step = env.step(policy(step))
    assert env.task.success(env.physics)
    assert env.task.held_band_height(env.physics) >= 0.05


def test_the_command_line_plays_records_and_replays_on_the_anatomical_abdomen(tmp_path):
    """--scene reaches the episode and the recording: a recorded grasp on the anatomical abdomen
    replays to the same final state, the scene read back from the file; an unknown scene is one
    line on stderr before anything runs."""
    import subprocess
    import sys
    from viscera import recording
    out = tmp_path / "grasp.npz"
    done = subprocess.run([sys.executable, "-m", "viscera", "record", "grasp_lift", "--scene", "anatomical",
                           "--seed", "1000", "--policy", "scripted", "--out", str(out), "--quiet"],
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    assert "grasp_lift, anatomical scene, seed 1000" in done.stdout
    made = recording.load(out)
    assert made.scene == "anatomical" and made.success
    assert recording.replay(made).matches(made)
    refused = subprocess.run([sys.executable, "-m", "viscera", "play", "grasp_lift", "--scene", "belly"],
                             capture_output=True, text=True, timeout=120)
    assert refused.returncode == 2 and len(refused.stderr.strip().splitlines()) == 1
    assert "--scene" in refused.stderr and "'belly'" in refused.stderr


def test_the_command_line_knows_every_scene():
    from viscera.__main__ import SCENES
    assert SCENES == tuple(scene.SCENES)
