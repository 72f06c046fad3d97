"""Sphere-grid collisions (paper 3.3): self-collision, the rigid world, friction,
momentum exchange and the tool force sensor, against numbers physics fixes."""

import mujoco
import numpy as np
import pytest

import viscera
from conftest import compile_scene

G = 9.81
R = 0.0125


def axis_min_separation(gut, data, points_per_sphere=2):
    """Smallest distance between axis points further apart along the rest axis
    than pi r (the documented neighbour rule), and the pair's arc distance."""
    count = (gut.sphere_count - 1) * points_per_sphere + 1
    x = gut.axis_points(data, count)
    arc = np.linspace(0.0, gut.rest_length, count)
    d = np.linalg.norm(x[:, None, :] - x[None, :, :], axis=-1)
    far = np.abs(arc[:, None] - arc[None, :]) >= np.pi * gut.radius
    return d[far].min()


def test_pile_never_passes_through_itself_or_the_floor():
    """The 4 m, 250-point intestine dropped into a pile: over 5 s, sampled every 10 ms, no two
    non-neighbouring axis points closer than 2r - 0.3r, no axis point below the floor by more
    than 0.3r. The first impact presses the lowest loop into the floor, and the loops into each
    other, by about a fifth of the radius whatever the substeps (into the floor 0.19 to 0.24 r at
    3, 8 and 16 a step; tube into tube 0.24 r at 3: the penalty's depth under the falling pile,
    not a step's error; sampled every 0.1 s the test saw less), so 0.3r is the bound the contact
    model holds to."""
    model, data, gut = compile_scene('<geom type="plane" size="2 2 .1"/>', length=4, control_points=250,
                                     shape="serpentine", box=[-0.1, -0.1, 0.05, 0.1, 0.1, 0.8])
    closest, lowest = np.inf, np.inf
    while data.time < 5.0:
        for _ in range(5):
            mujoco.mj_step(model, data)
        closest = min(closest, axis_min_separation(gut, data))
        lowest = min(lowest, gut.axis_points(data, 4000)[:, 2].min())
    top = gut.axis_points(data, 4000)[:, 2].max()
    assert top > 4 * R  # it did pile up: at least three layers deep
    assert closest > 2 * R - 0.3 * R, closest
    assert lowest > R - 0.3 * R, lowest
    assert gut.divergence_count(data) == 0


def test_straight_tube_starts_without_self_contact():
    model, data, gut = compile_scene(options='timestep="0.002" gravity="0 0 0"', damping=0, shape="line")
    q0 = gut.positions(data).copy()
    for _ in range(50):
        mujoco.mj_step(model, data)
    # a contact would push by ~ contact force / stiffness; only rounding moves it
    np.testing.assert_allclose(gut.positions(data), q0, rtol=0, atol=1e-12)


def test_cup_holds_the_intestine():
    """Dropped into a cup of MuJoCo geoms (a ring of boxes on a plate), it stays inside."""
    walls = "".join(
        f'<geom type="box" size="0.01 0.05 0.1" pos="{0.16 * np.cos(a):.5f} {0.16 * np.sin(a):.5f} 0.1" '
        f'euler="0 0 {np.degrees(a):.3f}"/>' for a in np.linspace(0, 2 * np.pi, 16, endpoint=False))
    cup = f'<geom type="plane" size="1 1 .1"/>{walls}'
    model, data, gut = compile_scene(cup, length=2.0, control_points=125, shape="serpentine",
                                     box=[-0.09, -0.09, 0.05, 0.09, 0.09, 0.5])
    while data.time < 3.0:
        mujoco.mj_step(model, data)
        if int(round(data.time / model.opt.timestep)) % 100 == 0:
            axis = gut.axis_points(data, 800)
            assert np.hypot(axis[:, 0], axis[:, 1]).max() < 0.16 - 0.01, data.time  # inside the wall faces
            assert axis[:, 2].min() > 0.8 * R
    assert gut.axis_points(data, 800)[:, 2].max() < 0.2  # settled in the cup


@pytest.mark.parametrize("degrees,slides", [(10.0, False), (25.0, True)])
def test_friction_holds_below_the_friction_angle_and_slides_above(degrees, slides):
    """mu = 0.3, friction angle atan(0.3) = 16.7 deg: at 10 deg it stays put, at 25 deg it slides
    down at about g (sin - mu cos)."""
    mu, angle = 0.3, np.radians(degrees)
    plate = f'<geom type="box" size="1 0.3 0.01" euler="0 {degrees} 0" friction="{mu} 0.005 0.0001"/>'
    down = np.array([-np.cos(angle), 0.0, np.sin(angle)])  # along the plate, in the frame's x
    start = np.array([0.3 * np.cos(angle), 0.0, -0.3 * np.sin(angle)]) + (0.01 + R) * np.array(
        [np.sin(angle), 0.0, np.cos(angle)])
    model, data, gut = compile_scene(plate, length=0.3, control_points=25, damping=0.5, shape="line",
                                     start=start, direction=down)
    while data.time < 0.5:  # settle onto the plate
        mujoco.mj_step(model, data)
    before = gut.positions(data).mean(axis=0)
    while data.time < 1.5:
        mujoco.mj_step(model, data)
    travelled = np.linalg.norm(gut.positions(data).mean(axis=0) - before)
    if slides:
        expected = 0.5 * G * (np.sin(angle) - mu * np.cos(angle)) * 1.0**2  # 1 s from rest (damping aside)
        assert travelled > 0.5 * expected
    else:
        assert travelled < 1e-3


def total_momentum(model, data, gut, box):
    """Linear momentum of intestine (integral of mu v ds) and box."""
    s = np.linspace(0.0, 1.0, 4001)
    v = viscera.spline_points(gut.velocities(data), s)
    rod = gut.mass * ((v[1:] + v[:-1]) * 0.5 * np.diff(s)[:, None]).sum(axis=0)  # trapezoid rule
    return rod + model.body_mass[box] * data.qvel[:3]


def test_momentum_is_exchanged_exactly_with_a_free_box():
    """Zero gravity: the intestine hits a free box; total linear momentum is conserved (1 %)."""
    body = '<body name="box" pos="0.6 0 0"><freejoint/><geom type="box" size="0.05 0.05 0.05" mass="0.5"/></body>'
    model, data, gut = compile_scene(body, options='timestep="0.002" gravity="0 0 0"', damping=0, length=0.5,
                                     control_points=30, shape="line", start=[0, 0.02, 0], direction=[1, 0, 0])
    gut.velocities(data)[:] = [1.0, 0.0, 0.0]
    box = model.body("box").id
    p0 = total_momentum(model, data, gut, box)
    hit = False
    while data.time < 0.6:
        mujoco.mj_step(model, data)
        hit |= np.linalg.norm(data.qvel[:3]) > 0.05
    assert hit  # the box was pushed
    p1 = total_momentum(model, data, gut, box)
    assert np.linalg.norm(p1 - p0) < 0.01 * np.linalg.norm(p0), (p0, p1)


def test_tool_force_sensor_reads_the_weight_of_a_draped_intestine():
    ext = viscera.extension_xml("gut", length=1.0, control_points=40, shape="line", start=[-0.5, 0, 1.02],
                                direction=[1, 0, 0], damping=3)
    xml = f"""<mujoco><option timestep="0.002"/>{ext}
      <worldbody><body name="tool" pos="0 0 1">
        <geom type="capsule" size="0.01 0.2" euler="90 0 0"/></body></worldbody>
      <sensor><plugin name="tool_force" instance="gut" objtype="body" objname="tool"/></sensor></mujoco>"""
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    gut = viscera.intestine(model)
    while data.time < 4.0:
        mujoco.mj_step(model, data)
    assert gut.positions(data)[:, 2].min() < 0.8  # draped: both halves hang
    weight = gut.mass * G
    force = data.sensor("tool_force").data
    assert force[2] == pytest.approx(-weight, rel=0.02)
    assert np.abs(force[:2]).max() < 0.02 * weight  # symmetric drape: no sideways pull
    mujoco.mj_forward(model, data)  # sensors were computed before the last advance: sync them
    np.testing.assert_allclose(gut.body_wrench(data, "tool")[:3], data.sensor("tool_force").data[:3])


def test_sensor_must_name_a_body():
    ext = viscera.extension_xml("gut", length=1.0, control_points=20)
    xml = f"""<mujoco>{ext}<worldbody><site name="s"/></worldbody>
      <sensor><plugin name="bad" instance="gut" objtype="site" objname="s"/></sensor></mujoco>"""
    with pytest.raises(ValueError, match="sensor 'bad' must name the body"):
        mujoco.MjModel.from_xml_string(xml)


def test_a_sliding_tool_feels_the_spheres_less_as_they_close_up():
    """A tool held 2 mm into a tube and slid along it (validation/contacts): its force swings by
    two fifths of its mean over spheres one radius apart, by under a tenth at half a radius; the
    penalty is per sphere, so the same indentation pushes about twice as hard."""
    from validation.contacts.study import ripple
    coarse, fine = ripple(1.0), ripple(0.5)
    assert coarse["ripple"] > 0.3 and fine["ripple"] < 0.1
    assert fine["mean_N"] == pytest.approx(2 * coarse["mean_N"], rel=0.15)
