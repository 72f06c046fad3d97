"""Grasping: a closing jaw holds the nearest axis point, opening releases it, pulling too hard slips."""

import copy

import mujoco
import numpy as np
import pytest

import viscera

RADIUS = 0.0125
LENGTH = 0.5


def scene(**grasp) -> str:
    """A 0.5 m intestine lying along x on a frictionless floor (with friction its bending holds a
    lifted arch up on its feet), and a hand (three slides) with a hinged jaw."""
    config = {"grasp_sites": "tip", "grasp_joints": "jaw", **grasp}
    return f"""
<mujoco>
  <option timestep="0.002"/>
  {viscera.extension_xml(length=LENGTH, control_points=20, radius=RADIUS, shape="line",
                         start=[0, 0, RADIUS], direction=[1, 0, 0], damping=3, friction=0, **config)}
  <worldbody>
    <geom name="floor" type="plane" size="1 1 0.1"/>
    <body name="hand" pos="0.25 0 0.1" gravcomp="1">
      <joint name="x" type="slide" axis="1 0 0" damping="20"/>
      <joint name="y" type="slide" axis="0 1 0" damping="20"/>
      <joint name="z" type="slide" axis="0 0 1" damping="20"/>
      <geom type="sphere" size="0.003" mass="0.1" contype="0" conaffinity="0"/>
      <site name="tip" pos="0 0 0"/>
      <body name="moving_jaw" gravcomp="1">
        <joint name="jaw" type="hinge" axis="0 1 0" range="0 0.7" damping="0.05"/>
        <geom type="capsule" fromto="0 0 0 0.01 0 -0.01" size="0.002" mass="0.01" contype="0" conaffinity="0"/>
      </body>
      <body name="wrist" gravcomp="1">
        <joint name="bad" type="ball"/>
        <geom type="sphere" size="0.002" mass="0.01" contype="0" conaffinity="0"/>
      </body>
    </body>
  </worldbody>
  <actuator>
    <position name="x" joint="x" kp="2000"/>
    <position name="y" joint="y" kp="2000"/>
    <position name="z" joint="z" kp="2000"/>
    <position name="jaw" joint="jaw" kp="2"/>
  </actuator>
</mujoco>"""


def move(model, data, seconds, x=None, z=None, jaw=None):
    """Ramp the hand's targets (offsets from its start, m; jaw in rad) over `seconds`, as a
    surgeon would: a tool yanked at metres per second tears the tissue out of the jaws."""
    start = data.ctrl.copy()
    goal = start.copy()
    for index, value in ((0, x), (2, z), (3, jaw)):
        if value is not None:
            goal[index] = value
    steps = int(round(seconds / model.opt.timestep))
    for step in range(steps):
        data.ctrl[:] = start + (goal - start) * min(1.0, (step + 1) / (0.7 * steps))
        mujoco.mj_step(model, data)


def held_point(gut, data, abscissa_m):
    return viscera.spline_points(gut.positions(data), np.array([abscissa_m / gut.rest_length]))[0]


def test_closing_holds_the_nearest_point_and_opening_releases_it():
    model = mujoco.MjModel.from_xml_string(scene())
    data = mujoco.MjData(model)
    gut = viscera.intestine(model)
    move(model, data, 0.3, jaw=0.6)                 # open, above x = 0.25
    assert gut.grasps(data)[0].status == "open"
    move(model, data, 0.5, z=-0.1 + 0.004)          # down onto the tube's axis
    move(model, data, 0.3, jaw=0.0)                 # close
    grasp = gut.grasps(data)[0]
    assert grasp.status == "holding"
    assert grasp.abscissa == pytest.approx(0.25, abs=0.01)
    move(model, data, 1.0, z=0.0)                   # lift 10 cm
    tip = data.site("tip").xpos
    point = held_point(gut, data, grasp.abscissa)
    assert np.linalg.norm(point - tip) < 0.01       # the held point came along
    assert point[2] > 0.08
    # momentum balance: the hand carries the lifted tube (a downward pull, less than the
    # whole tube's weight since its ends still rest on the floor)
    force = gut.body_wrench(data, "hand")[:3]
    assert -gut.mass * 9.81 < force[2] < -0.1 * gut.mass * 9.81
    move(model, data, 1.5, jaw=0.6)                 # open: it falls back
    assert gut.grasps(data)[0].status == "open"
    assert held_point(gut, data, grasp.abscissa)[2] < 2 * RADIUS
    assert gut.divergence_count(data) == 0


def test_pulling_harder_than_the_slip_force_slips():
    model = mujoco.MjModel.from_xml_string(scene(grasp_slip_force=0.3))
    data = mujoco.MjData(model)
    gut = viscera.intestine(model)
    move(model, data, 0.3, jaw=0.6)
    move(model, data, 0.5, z=-0.1 + 0.004)
    move(model, data, 0.3, jaw=0.0)
    assert gut.grasps(data)[0].holding
    move(model, data, 1.0, z=0.0)  # the lifted tube weighs more than 0.3 N
    grasp = gut.grasps(data)[0]
    assert grasp.status == "closed" and grasp.slips == 1
    move(model, data, 1.5)
    assert gut.positions(data)[:, 2].max() < 2 * RADIUS  # back on the floor
    move(model, data, 0.3, jaw=0.6)  # reopening makes the jaw ready again
    assert gut.grasps(data)[0].status == "open"


def test_a_jaw_closing_out_of_reach_holds_nothing():
    model = mujoco.MjModel.from_xml_string(scene())
    data = mujoco.MjData(model)
    gut = viscera.intestine(model)
    move(model, data, 0.3, jaw=0.6)
    move(model, data, 0.3, jaw=0.0)  # 10 cm above the tube: beyond the 2-radius reach
    assert gut.grasps(data)[0].status == "closed"
    assert (gut.body_wrench(data, "hand") == 0).all()


def test_a_copy_taken_while_holding_steps_identically():
    model = mujoco.MjModel.from_xml_string(scene())
    data = mujoco.MjData(model)
    move(model, data, 0.3, jaw=0.6)
    move(model, data, 0.5, z=-0.1 + 0.004)
    move(model, data, 0.3, jaw=0.0)
    twin = copy.copy(data)
    move(model, data, 0.5, z=0.0)
    move(model, twin, 0.5, z=0.0)
    np.testing.assert_array_equal(data.plugin_state, twin.plugin_state)
    np.testing.assert_array_equal(data.qpos, twin.qpos)


@pytest.mark.parametrize("config, message", [
    ({"grasp_sites": "nowhere"}, "'grasp_sites' = 'nowhere': the model has no site named 'nowhere'"),
    ({"grasp_joints": "jaw x"}, "must name as many sites as joints"),
    ({"grasp_joints": "bad"}, "'grasp_joints' = 'bad': joint 'bad' must be a hinge or a slide"),
    ({"grasp_stiffness": "-1"}, "'grasp_stiffness' = '-1' must be >= 0"),
    ({"grasp_slip_force": "0"}, "'grasp_slip_force' = '0' must be positive"),
    ({"grasp_reach": "nan"}, "'grasp_reach' = 'nan' is not a finite number"),
])
def test_bad_grasp_config_is_refused_at_load(config, message):
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)")):
        mujoco.MjModel.from_xml_string(scene(**config))
