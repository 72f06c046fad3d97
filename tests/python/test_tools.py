"""Trocar tools: scripted trajectories, the remote centre of motion, velocity limits."""

import json

import mujoco
import numpy as np
import pytest

import viscera  # noqa: F401  (registers the plugin)
from viscera.trajectory import COORDINATES, DEFAULT_MAX_VELOCITY, ToolPlayer, ToolTrajectory

from test_package import ROOT

ABDOMEN = ROOT / "assets" / "scenes" / "abdomen.xml"

SWEEP = [
    {"time": 0.0},
    {"time": 1.0, "depth": 0.08},
    {"time": 2.0, "pitch": 25.0, "yaw": -15.0, "depth": 0.12, "roll": 40.0, "jaw": 30.0},
    {"time": 3.0, "pitch": -20.0, "yaw": 20.0},
    {"time": 4.0, "depth": 0.02},
]


def test_shaft_passes_through_the_trocar_for_a_whole_trajectory():
    """The remote centre of motion: the shaft line stays within 1 mm of the trocar point."""
    model = mujoco.MjModel.from_xml_path(str(ABDOMEN))
    data = mujoco.MjData(model)
    player = ToolPlayer(model, "grasper", ToolTrajectory(SWEEP))
    shaft, trocar = model.geom("grasper_shaft").id, model.site("grasper_trocar").id
    worst, moved = 0.0, 0.0
    start = None
    while data.time < player.trajectory.duration + 0.5:
        player.apply(data)
        mujoco.mj_step(model, data)
        axis = data.geom_xmat[shaft].reshape(3, 3)[:, 2]  # the capsule's axis
        offset = data.site_xpos[trocar] - data.geom_xpos[shaft]
        worst = max(worst, np.linalg.norm(offset - np.dot(offset, axis) * axis))
        start = data.geom_xpos[shaft].copy() if start is None else start
        moved = max(moved, np.linalg.norm(data.geom_xpos[shaft] - start))
    assert moved > 0.05  # the tool did sweep about
    assert worst < 1e-3, worst


def test_tool_follows_its_targets():
    model = mujoco.MjModel.from_xml_path(str(ABDOMEN))
    data = mujoco.MjData(model)
    player = ToolPlayer(model, "grasper", ToolTrajectory(SWEEP))
    while data.time < player.trajectory.duration + 1.0:
        target = player.apply(data)
        mujoco.mj_step(model, data)
    joints = [model.joint(f"grasper_{c}").id for c in COORDINATES]
    reached = np.array([data.qpos[model.jnt_qposadr[j]] for j in joints])
    expected = target * np.array([np.pi / 180, np.pi / 180, 1.0, np.pi / 180, np.pi / 180])
    np.testing.assert_allclose(reached, expected, atol=0.02)  # 1 degree, 2 cm at worst


def test_velocity_limits_hold_by_retiming(tmp_path):
    spec = {"waypoints": [{"time": 0.0}, {"time": 0.1, "depth": 0.2}], "max_velocity": {"depth": 0.05}}
    path = tmp_path / "fast.json"
    path.write_text(json.dumps(spec))
    trajectory = ToolTrajectory.from_file(str(path))
    assert trajectory.duration == pytest.approx(1.875 * 0.2 / 0.05)  # stretched from 0.1 s to 7.5 s
    times = np.linspace(0.0, trajectory.duration, 2001)
    depth = np.array([trajectory(t)[2] for t in times])
    speed = np.abs(np.diff(depth)) / np.diff(times)
    assert speed.max() <= 0.05 * 1.001
    assert depth[-1] == pytest.approx(0.2) and depth[0] == 0.0


def test_bad_waypoints_are_clear_errors():
    with pytest.raises(ValueError, match="depht"):
        ToolTrajectory([{"time": 0.0, "depht": 0.1}])
    with pytest.raises(ValueError, match="backwards"):
        ToolTrajectory([{"time": 1.0}, {"time": 0.5}])
    with pytest.raises(ValueError, match="max_velocity"):
        ToolTrajectory([{"time": 0.0}], {"depth": -1.0})
    assert set(DEFAULT_MAX_VELOCITY) == set(COORDINATES)


def test_abdomen_holds_the_intestine():
    model = mujoco.MjModel.from_xml_path(str(ABDOMEN))
    data = mujoco.MjData(model)
    gut = viscera.intestine(model)
    while data.time < 1.5:
        mujoco.mj_step(model, data)
    axis = gut.axis_points(data, 1000)
    assert gut.divergence_count(data) == 0
    assert (np.abs(axis[:, 0]) < 0.15).all() and (np.abs(axis[:, 1]) < 0.125).all()
    assert axis[:, 2].min() > 0.8 * gut.radius and axis[:, 2].max() < 0.15
