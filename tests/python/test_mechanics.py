"""Mechanics through the plugin, against numbers physics fixes."""

import mujoco
import numpy as np
import pytest

import viscera
from conftest import compile_scene

G = 9.81


@pytest.mark.parametrize("integrator", ["Euler", "RK4", "implicitfast"])
def test_free_fall_is_exact_under_every_mujoco_integrator(integrator):
    """Without contact or damping every control point falls at g: v = g t to 1e-6.

    Under MuJoCo's RK4 the plugin's compute runs four times a step; the rod
    must still advance exactly once.
    """
    model, data, gut = compile_scene(options=f'timestep="0.002" integrator="{integrator}"', damping=0,
                                     shape="line", start=[0, 0, 10], direction=[1, 1, 0.3])
    q0 = gut.positions(data).copy()
    for _ in range(100):
        mujoco.mj_step(model, data)
    t = data.time
    expected_v = np.array([0, 0, -G * t])
    np.testing.assert_allclose(gut.velocities(data), np.broadcast_to(expected_v, (250, 3)), rtol=0, atol=1e-6 * G * t)
    drop = q0[:, 2] - gut.positions(data)[:, 2]
    np.testing.assert_allclose(drop, 0.5 * G * t * t, rtol=1e-6)


def test_damping_decays_velocity_at_its_rate():
    """damping c (1/s): a uniform velocity decays as exp(-c t) (no gravity, no strain)."""
    model, data, gut = compile_scene(options='timestep="0.002" gravity="0 0 0"', damping=2.0, shape="line")
    gut.velocities(data)[:] = [0.3, -0.2, 0.1]
    for _ in range(250):
        mujoco.mj_step(model, data)
    np.testing.assert_allclose(gut.velocities(data), np.broadcast_to([0.3, -0.2, 0.1], (250, 3)) * np.exp(-2.0 * data.time),
                               rtol=1e-8)


def test_catenary_sag():
    """4 m, ends pinned 3 m apart, stiff stretch, settled: sag a(cosh(D/2a)-1) = 1.177335 m within 1 %."""
    depth = np.sqrt(2.0**2 - 1.5**2)  # start as a V of the right length
    model, data, gut = compile_scene(options='timestep="0.001"', length=4, control_points=100, stretch_stiffness=100,
                                     bend_stiffness=0, global_stretch_stiffness=5000, damping=4, substeps=2,
                                     shape="polyline", points=[-1.5, 0, 2, 0, 0, 2 - depth, 1.5, 0, 2], pinned=[0, 99])
    ends = gut.positions(data)[[0, -1]].copy()
    while data.time < 6.0:
        mujoco.mj_step(model, data)
    np.testing.assert_array_equal(gut.positions(data)[[0, -1]], ends)  # pinned points do not move
    assert np.abs(gut.velocities(data)).max() < 1e-3  # settled
    sag = 2.0 - gut.axis_points(data, 20001)[:, 2].min()
    assert sag == pytest.approx(1.177335, rel=0.01)
    assert gut.length(data) == pytest.approx(4.0, rel=0.003)


def test_hanging_rod_stretches_by_mgL_over_2EA():
    """A rod hanging from its top stretches by m g / (2 k) for whole-length axial stiffness k."""
    k = 10.0 + 4 * 1.0 + 200.0  # stretch + 4 bend + global (README: axial stiffness)
    model, data, gut = compile_scene(options='timestep="0.002"', length=1.0, control_points=60, damping=5,
                                     shape="line", start=[0, 0, 2], direction=[0, 0, -1], pinned=[0],
                                     stretch_stiffness=10, bend_stiffness=1, global_stretch_stiffness=200)
    mass = 1000 * np.pi * 0.0125**2 * 1.0
    while data.time < 6.0:
        mujoco.mj_step(model, data)
    stretch = gut.length(data) - 1.0
    assert stretch == pytest.approx(mass * G / (2 * k), rel=0.05)


def test_rests_on_a_plane_at_its_radius():
    """At rest the penalty forces carry the weight: sum k (r - z_i) = m g over the spheres,
    and the interior spheres, a spacing of weight each, sink by m g / ((S - 1) k)."""
    model, data, gut = compile_scene('<geom type="plane" size="3 3 0.1"/>', length=1.0, control_points=40, damping=5,
                                     shape="line", start=[0, 0, 0.1], direction=[1, 0, 0])
    while data.time < 3.0:
        mujoco.mj_step(model, data)
    assert np.abs(gut.velocities(data)[:, 2]).max() < 1e-6  # vertically at rest
    weight = 1000 * np.pi * 0.0125**2 * 1.0 * G
    penetration = 0.0125 - gut.sphere_centres(data)[:, 2]
    assert (penetration > 0).all()
    assert 2000.0 * penetration.sum() == pytest.approx(weight, rel=1e-4)  # default contact_stiffness 2000 N/m
    interior = penetration[12:-12]  # away from the ends (their half-loaded spheres and end segments)
    np.testing.assert_allclose(interior, weight / ((gut.sphere_count - 1) * 2000.0), rtol=1e-3)


def _box_displacement(model, data, duration=1.0):
    box = model.body("box").id
    mujoco.mj_forward(model, data)
    start = data.xpos[box].copy()
    while data.time < duration:
        mujoco.mj_step(model, data)
    return data.xpos[box] - start


def test_falling_intestine_pushes_a_free_box(falling_line):
    """The reaction goes into qfrc_passive: the box is shoved sideways and pressed down."""
    model, data, gut = falling_line
    moved = _box_displacement(model, data)
    assert np.hypot(moved[0], moved[1]) > 1e-3, moved
    # pressed into MuJoCo's soft floor contact deeper than by its own weight (1e-4 m)
    assert moved[2] < -2e-4, moved
    box_x = data.xpos[model.body("box").id][0]
    over_box = np.abs(gut.positions(data)[:, 0] - box_x) < 0.03
    assert gut.positions(data)[over_box, 2].min() > 0.09  # the intestine lies on top of it


def test_box_out_of_reach_does_not_move(falling_line):
    model, data, gut = falling_line
    data.qpos[model.jnt_qposadr[model.body_jntadr[model.body("box").id]]] = 2.0  # slide the box away
    moved = _box_displacement(model, data)
    assert np.hypot(moved[0], moved[1]) < 1e-9
    assert -2e-4 < moved[2] <= 0.0  # only MuJoCo's own soft-contact settling


@pytest.mark.parametrize("length", [0.4, 1.0, 8.0])
def test_defaults_are_stable_at_any_length(length):
    """Defaults describe one material at every length: short and long intestines
    drop onto a plane and settle at the default step without a single divergence."""
    points = max(8, int(round(62.5 * length)))
    model, data, gut = compile_scene('<geom type="plane" size="10 10 .1"/>', length=length, control_points=points,
                                     shape="line", start=[0, 0, 0.2], direction=[1, 0, 0.05])
    while data.time < 1.0:
        mujoco.mj_step(model, data)
    assert gut.divergence_count(data) == 0
    assert gut.length(data) == pytest.approx(length, rel=0.02)


def test_mesentery_holds_the_bowel_within_its_reach():
    """Zero gravity, thrown away from its root at 1 m/s: the tension-only tethers stop every
    point within slack + a small stretch of its root point; without them it flies away."""
    distances = {}
    for stiffness in (0.0, 50.0):
        config = dict(length=0.6, control_points=40, shape="line", start=[-0.3, 0, 0.05], damping=2,
                      mesentery_stiffness=stiffness, mesentery_length=0.1, mesentery_points=16)
        if stiffness:
            config["mesentery_root"] = [-0.3, 0, 0, 0.3, 0, 0]
        model, data, gut = compile_scene(options='timestep="0.002" gravity="0 0 0"', **config)
        gut.velocities(data)[:] = [0.0, 0.0, 1.0]
        while data.time < 2.0:
            mujoco.mj_step(model, data)
        s = (np.arange(16) + 0.5) / 16
        tethered = viscera.spline_points(gut.positions(data), s)
        roots = np.stack([-0.3 + 0.6 * s, np.zeros(16), np.zeros(16)], axis=1)
        distances[stiffness] = np.linalg.norm(tethered - roots, axis=1).max()
    assert distances[0.0] > 0.5  # free: carried far away
    assert distances[50.0] < 0.1 + 0.02  # held: slack plus a small stretch


def test_mesentery_needs_its_root():
    with pytest.raises(ValueError, match="mesentery_root"):
        compile_scene(mesentery_stiffness=10.0)


def test_clamped_ends_hold_place_and_direction():
    """clamped="both": with the paper's springs (no EI) the two end control points at each end are
    pinned. With a bending rigidity only the end one is (its neighbour moves) and the clamp term
    holds the end tangent: at rest the end slope is a small fraction of the beam's largest slope,
    and it falls at second order with the spacing."""
    model, data, gut = compile_scene(length=1.0, control_points=12, damping=5, self_collision=0, shape="line",
                                     clamped="both")
    q0 = gut.positions(data).copy()
    while data.time < 1.0:
        mujoco.mj_step(model, data)
    q = gut.positions(data)
    np.testing.assert_array_equal(q[[0, 1, -2, -1]], q0[[0, 1, -2, -1]])
    assert q[5, 2] < -1e-3  # the middle sags
    end_slopes = []
    for n in (12, 24):
        model, data, gut = compile_scene(length=1.0, control_points=n, damping=20, self_collision=0, shape="line",
                                         clamped="both", young_modulus=1e7, substeps=8 * (n // 12) ** 2)
        q0 = gut.positions(data).copy()
        while data.time < 2.0:
            mujoco.mj_step(model, data)
        q = gut.positions(data)
        np.testing.assert_array_equal(q[[0, -1]], q0[[0, -1]])
        assert q[1, 2] < -1e-6  # the neighbour is free and moves
        points = gut.axis_points(data, 2001)
        slope = np.diff(points[:, 2]) / np.diff(points[:, 0])
        assert abs(slope[0]) < 0.25 * np.abs(slope).max()
        end_slopes.append(abs(slope[0]))
    assert end_slopes[1] < 0.35 * end_slopes[0]
