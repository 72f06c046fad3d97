"""The intestine rests on every primitive MuJoCo geom type, honouring contype/conaffinity."""

import mujoco
import numpy as np
import pytest

from conftest import compile_scene

# Static geoms whose top is at z = 0.1 under the middle of the intestine.
GEOMS = {
    "plane": '<geom type="plane" size="2 2 0.1" pos="0 0 0.1"/>',
    "sphere": '<geom type="sphere" size="0.1" pos="0 0 0"/>',
    "capsule": '<geom type="capsule" size="0.05 0.3" pos="0 0 0.05" euler="90 0 0"/>',
    "cylinder": '<geom type="cylinder" size="0.1 0.05" pos="0 0 0.05"/>',
    "box": '<geom type="box" size="0.1 0.1 0.05" pos="0 0 0.05"/>',
    "ellipsoid": '<geom type="ellipsoid" size="0.15 0.2 0.1" pos="0 0 0"/>',
    "mesh": '<geom type="mesh" mesh="slab" pos="0 0 0.05"/>',
    "hfield": '<geom type="hfield" hfield="ground" pos="0 0 0.1"/>',  # MuJoCo normalises a flat field to 0
}
# a convex slab mesh (as a box of 0.1 x 0.1 x 0.05 half sizes) and a flat height field
ASSETS = ('<mesh name="slab" vertex="-.1 -.1 -.05  .1 -.1 -.05  -.1 .1 -.05  .1 .1 -.05  '
          '-.1 -.1 .05  .1 -.1 .05  -.1 .1 .05  .1 .1 .05"/>'
          '<hfield name="ground" nrow="3" ncol="3" size="0.3 0.3 0.1 0.05" elevation="1 1 1 1 1 1 1 1 1"/>')


@pytest.mark.parametrize("kind", sorted(GEOMS))
def test_rests_on_each_geom_type(kind):
    model, data, gut = compile_scene(GEOMS[kind], assets=ASSETS, length=0.4, control_points=30, damping=3,
                                     shape="line", start=[-0.2, 0, 0.3], direction=[1, 0, 0])
    while data.time < 1.5:
        mujoco.mj_step(model, data)
    axis = gut.axis_points(data, 400)
    over_top = axis[np.argmin(np.hypot(axis[:, 0], axis[:, 1]))]  # the axis point above the geom's top
    assert np.hypot(over_top[0], over_top[1]) < 0.005  # it still covers the top
    assert over_top[2] == pytest.approx(0.1 + 0.0125, abs=0.003)


def test_contype_conaffinity_filter_geoms_out():
    model, data, gut = compile_scene('<geom type="box" size="0.1 0.1 0.05" pos="0 0 0.05" contype="2" conaffinity="2"/>',
                                     length=0.4, control_points=30, shape="line", start=[-0.2, 0, 0.3])
    while data.time < 0.5:
        mujoco.mj_step(model, data)
    assert gut.positions(data)[:, 2].max() < 0.0  # fell straight through


def test_disabled_contacts_are_respected():
    model, data, gut = compile_scene('<geom type="plane" size="2 2 .1"/>', options='timestep="0.002"><flag contact="disable"/></option><option',
                                     length=0.4, control_points=30, shape="line", start=[-0.2, 0, 0.3])
    while data.time < 0.5:
        mujoco.mj_step(model, data)
    assert gut.positions(data)[:, 2].max() < 0.0


def test_passive_forces_disabled_is_reported_once(capfd, caplog):
    """With both spring and damper disabled MuJoCo skips plugin compute: say so, once."""
    model, data, gut = compile_scene('<geom type="plane" size="2 2 .1"/>',
                                     options='timestep="0.002"><flag spring="disable" damper="disable"/></option><option',
                                     length=0.4, control_points=30, shape="line", start=[-0.2, 0, 0.05])
    for _ in range(50):
        mujoco.mj_step(model, data)
    printed = capfd.readouterr()
    text = printed.out + printed.err + caplog.text
    assert text.count("spring and damper flags are both disabled") == 1
    assert gut.positions(data)[:, 2].min() > 0.0  # the intestine itself still rests on the plane
