"""A tapered tube (config `radius` with two values, docs/model.md#taper): its spheres, contacts,
skin, drawing and mass follow the local radius, linear along the rest length."""

import mujoco
import numpy as np
import pytest

import viscera

R0, R1, LENGTH = 0.015, 0.008, 0.6


def tube(radius="0.015 0.008", **keys):
    xml = (f'<mujoco><option timestep="0.002"/>'
           + viscera.extension_xml("gut", length=LENGTH, radius=radius, control_points=24, shape="line",
                                   start=[0, 0, 0.05], direction=[1, 0, 0], damping=5, **keys)
           + '<worldbody><geom name="floor" type="plane" size="1 1 0.1"/></worldbody></mujoco>')
    model = mujoco.MjModel.from_xml_string(xml)
    return model, mujoco.MjData(model), viscera.intestine(model)


def test_a_tapered_tube_rests_on_a_plane_with_each_end_at_its_own_radius():
    model, data, gut = tube()
    assert gut.radius == R0 and gut.radius_end == R1
    for _ in range(int(3.0 / model.opt.timestep)):
        mujoco.mj_step(model, data)
    axis = gut.axis_points(data, 101)
    s = np.linspace(0.0, 1.0, 101)
    expected = R0 + s * (R1 - R0)
    # penalty contacts sink the spheres by m g / k each, hundredths of a millimetre
    np.testing.assert_allclose(axis[:, 2], expected, atol=3e-4)
    assert axis[0, 2] - axis[-1, 2] == pytest.approx(R0 - R1, abs=3e-4)


def test_its_mass_follows_the_section_and_its_spheres_the_thin_end():
    model, data, gut = tube(density=1000)
    mean_square = (R0 ** 2 + R0 * R1 + R1 ** 2) / 3.0
    assert gut.mass == pytest.approx(1000 * np.pi * mean_square * LENGTH, rel=1e-12)
    assert gut.sphere_count == int(np.ceil(LENGTH / R1)) + 1  # spaced at most the thin end's radius
    # resting, the floor carries the weight, more of it under the thick end (radius^2)
    for _ in range(int(2.0 / model.opt.timestep)):
        mujoco.mj_step(model, data)
    wrench = gut.body_wrench(data, 0)
    assert -wrench[2] == pytest.approx(gut.mass * 9.81, rel=0.02)
    assert wrench[4] != pytest.approx(0.0, abs=1e-3)  # the load's centre is off the middle, towards the thick end


def test_one_radius_is_the_untapered_tube_and_bad_ones_are_refused():
    model, data, gut = tube(radius="0.012")
    assert gut.radius == gut.radius_end == 0.012
    for bad, why in (("0.012 0", "must be positive"), ("0.01 0.02 0.03", "one positive number, or two"),
                     ("x", "one positive number, or two")):
        with pytest.raises(ValueError, match=f"'radius' = '{bad}'.*{why}"):
            tube(radius=bad)
    with pytest.raises(ValueError, match="tapers the tube, and 'young_modulus'"):
        tube(young_modulus=3e5)


def test_the_skin_and_the_drawing_taper():
    model, data, gut = tube()
    mujoco.mj_forward(model, data)
    vertices, _, _ = viscera.skin(model, data, gut.instance)
    rings = (gut.control_count - 1) * 4 + 1
    points = (len(vertices) - 2) // rings
    ring = vertices[:rings * points].reshape(rings, points, 3)
    radii = np.linalg.norm(ring - ring.mean(axis=1, keepdims=True), axis=2).mean(axis=1)
    np.testing.assert_allclose(radii[[0, -1]], [R0, R1], rtol=1e-6)
    scene = mujoco.MjvScene(model, maxgeom=4000)
    mujoco.mjv_updateScene(model, data, mujoco.MjvOption(), None, mujoco.MjvCamera(), mujoco.mjtCatBit.mjCAT_ALL,
                           scene)
    capsules = [scene.geoms[i] for i in range(scene.ngeom) if scene.geoms[i].objtype == mujoco.mjtObj.mjOBJ_PLUGIN]
    assert capsules[0].size[0] == pytest.approx(R0, rel=0.01) and capsules[-1].size[0] == pytest.approx(R1, rel=0.01)
