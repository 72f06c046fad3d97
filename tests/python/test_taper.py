"""A tapered tube (config `radius` with two values, docs/model.md#taper): its spheres, contacts,
skin, drawing and mass follow the local radius, linear along the rest length."""

import mujoco
import numpy as np
import pytest

import viscera
from validation.common import relax

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
    with pytest.raises(ValueError, match="'wall_thickness' needs 'young_modulus' or a tapered 'radius'"):
        tube(radius="0.012", wall_thickness=0.002)


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


def _quadrature(radius, length, count=20001):
    """Abscissae x (m) on [0, length] and the solid section's A(x) (m^2) and I(x) (m^4)."""
    x = np.linspace(0.0, length, count)
    r = radius[0] + (radius[1] - radius[0]) * x / length
    return x, np.pi * r**2, np.pi * r**4 / 4.0


def _tail_integral(f, x):
    """F(x) = integral of f from x to the end (trapezoids)."""
    pieces = 0.5 * (f[1:] + f[:-1]) * np.diff(x)
    return np.concatenate([np.cumsum(pieces[::-1])[::-1], [0.0]])


@pytest.mark.parametrize("radius", [(0.015, 0.008), (0.008, 0.015)])
def test_a_tapered_rod_hanging_stretches_as_its_section_carries_the_weight_below(radius):
    """EA follows the local area: the stretch is the integral of N(x) / (E A(x)), N the weight
    below x (density g times the volume below), whichever end hangs from the pin."""
    young, length, density = 2.0e5, 1.0, 1000.0
    config = dict(length=length, control_points=24, radius=f"{radius[0]} {radius[1]}", density=density,
                  young_modulus=young, damping=6, self_collision=0, shape="line", direction=[0, 0, -1], pinned=[0])
    data, gut, _ = relax(config, 5.0, 0.001)
    x, area, _ = _quadrature(radius, length)
    weight_below = density * 9.81 * _tail_integral(area, x)
    f = weight_below / (young * area)
    expected = np.sum(0.5 * (f[1:] + f[:-1]) * np.diff(x))
    assert gut.length(data) - length == pytest.approx(expected, rel=0.01)


@pytest.mark.parametrize("radius", [(0.0125, 0.008), (0.008, 0.0125)])
def test_a_tapered_cantilever_bends_as_its_section_carries_the_moment(radius):
    """EI follows the local second moment: under its own weight (mass as r^2), the tip
    deflection is the integral of M(x) (L - x) / (E I(x)), M the moment of the weight beyond x.
    Clamped at the thick end the tip falls less than clamped at the thin one."""
    length, density, young = 0.5, 1000.0, 4.0e8
    config = dict(length=length, control_points=16, radius=f"{radius[0]} {radius[1]}", density=density,
                  young_modulus=young, stretch_stiffness=2000, damping=30, divergence_retries=0,
                  self_collision=0, shape="line", direction=[1, 0, 0], clamped="start")
    data, gut, _ = relax(config, 0.6, 0.001)
    tip = -gut.axis_points(data, 2)[-1][2]
    x, area, moment = _quadrature(radius, length)
    w = density * 9.81 * area  # N/m
    # M(x) = integral_x^L w(xi) (xi - x) dxi = integral_x^L w xi - x integral_x^L w
    bending = _tail_integral(w * x, x) - x * _tail_integral(w, x)
    f = bending * (length - x) / (young * moment)
    expected = np.sum(0.5 * (f[1:] + f[:-1]) * np.diff(x))
    assert 0.002 < expected < 0.05 * length  # small deflections: the linear beam holds
    assert tip == pytest.approx(expected, rel=0.005)
