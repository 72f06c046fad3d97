"""Clear the target area: move the bowel off a patch of the posterior wall.

Suite-style task (a Physics with named accessors, a Task, a load() front door)
on assets/scenes/abdomen.xml. Actions: the tools' position actuators (their
control ranges). Observations, in order: tool joint positions, the force the
intestine exerts on each tool (the tool force sensors), whether the grasper
holds the intestine, intestine axis points
(`axis_samples`, default 100, evenly along the axis, m), and the target's coverage grid. Reward: the fraction
of the target area uncovered, in [0, 1]: the target rectangle is sampled on a
10 x 10 grid of points, and a point is covered when the intestine's tube lies
over it (an axis point within one radius of it in the wall's plane). The
episode ends after `time_limit` s or when the area is uncovered (reward 1).
"""

from __future__ import annotations

import collections
import pathlib

import numpy as np
from dm_control import mujoco as dm_mujoco
from dm_control.rl import control
from dm_control.suite import base

import viscera
from viscera.checks import checked_integer

SCENE = pathlib.Path(__file__).resolve().parents[3] / "assets" / "scenes" / "abdomen.xml"
GRID = 10            # target sampling points per side
AXIS_SAMPLES = 100   # intestine axis points observed (3 cm apart on 3 m)
TOOLS = ("grasper", "retractor")


def _scene_path() -> pathlib.Path:
    """The scene, from the source tree or the installed package's data."""
    packaged = pathlib.Path(__file__).resolve().parent.parent / "assets" / "abdomen.xml"
    return SCENE if SCENE.exists() else packaged


class Physics(dm_mujoco.Physics):
    """The abdomen with named accessors for the task."""

    def intestine(self) -> viscera.Intestine:
        model = self.model.ptr
        cached = getattr(self, "_intestine", None)
        if cached is None or cached.model is not model:  # physics.reload_from_* replaces the model
            cached = self._intestine = viscera.intestine(model)
        return cached

    def axis_points(self, count: int = AXIS_SAMPLES) -> np.ndarray:
        return self.intestine().axis_points(self.data.ptr, count)

    def target_points(self) -> np.ndarray:
        """The GRID x GRID sampling points of the target rectangle (m, world frame)."""
        centre = self.named.data.site_xpos["target_area"]
        half = self.named.model.site_size["target_area"][:2]
        u = (np.arange(GRID) + 0.5) / GRID * 2.0 - 1.0
        x, y = np.meshgrid(centre[0] + u * half[0], centre[1] + u * half[1])
        return np.stack([x.ravel(), y.ravel(), np.full(GRID * GRID, centre[2])], axis=1)

    def coverage(self) -> np.ndarray:
        """1 where the tube lies over a target point (within one radius in the wall's plane)."""
        key = (self.data.time, self.intestine().positions(self.data.ptr).tobytes())
        if getattr(self, "_coverage_key", None) != key:  # reward, termination and observation share it
            gut = self.intestine()
            axis = gut.axis_points(self.data.ptr, 4 * gut.sphere_count)[:, :2]
            points = self.target_points()[:, :2]
            low, high = points.min(axis=0) - gut.radius, points.max(axis=0) + gut.radius
            near = axis[np.all((axis >= low) & (axis <= high), axis=1)]  # the rest cannot cover
            covered = np.zeros(len(points))
            if len(near):
                squared = ((points[:, None, :] - near[None, :, :]) ** 2).sum(axis=-1)
                covered = (squared.min(axis=1) <= gut.radius ** 2).astype(float)
            self._coverage_key, self._coverage = key, covered
        return self._coverage.copy()

    def uncovered_fraction(self) -> float:
        return float(1.0 - self.coverage().mean())

    def tool_forces(self) -> np.ndarray:
        return np.concatenate([self.named.data.sensordata[f"{tool}_force"] for tool in TOOLS])

    def holding(self) -> np.ndarray:
        """1 where a grasper holds the intestine (one entry per grasp site)."""
        return np.array([float(g.holding) for g in self.intestine().grasps(self.data.ptr)])

    def tool_joints(self) -> np.ndarray:
        names = [j for j in self.named.data.qpos.axes.row.names if j.split("_")[0] in TOOLS]
        return self.named.data.qpos[names].copy()


MAX_AXIS_SAMPLES = 100_000


class ClearArea(base.Task):
    """Uncover the target area; reward is the uncovered fraction."""

    def __init__(self, random=None, end_on_success: bool = True, axis_samples: int = AXIS_SAMPLES):
        super().__init__(random=random)
        self.end_on_success = end_on_success
        self.axis_samples = axis_samples

    def initialize_episode(self, physics: Physics) -> None:
        # the intestine starts from the scene's shape (reset writes it); tools start withdrawn
        super().initialize_episode(physics)

    def get_observation(self, physics: Physics) -> collections.OrderedDict:
        observation = collections.OrderedDict()
        observation["tool_joints"] = physics.tool_joints()
        observation["tool_forces"] = physics.tool_forces()
        observation["grasper_holding"] = physics.holding()
        observation["intestine_axis"] = physics.axis_points(self.axis_samples).ravel()
        observation["target_coverage"] = physics.coverage()
        return observation

    def get_reward(self, physics: Physics) -> float:
        return physics.uncovered_fraction()

    def get_termination(self, physics: Physics):
        return 0.0 if self.end_on_success and physics.uncovered_fraction() >= 1.0 else None


def load(seed: int | None = None, time_limit: float = 20.0, control_timestep: float = 0.02,
         end_on_success: bool = True, axis_samples: int = AXIS_SAMPLES) -> control.Environment:
    """The clear_area environment (time limit and control period in s; with end_on_success
    False an uncovered target does not end the episode, e.g. to watch a gesture finish;
    axis_samples: the intestine axis points observed, fewer for less data per step)."""
    axis_samples = checked_integer("axis_samples", axis_samples, 2)
    if axis_samples > MAX_AXIS_SAMPLES:
        raise ValueError(f"axis_samples = {axis_samples}: must be at most {MAX_AXIS_SAMPLES}")
    physics = Physics.from_xml_path(str(_scene_path()))
    task = ClearArea(random=np.random.RandomState(seed), end_on_success=end_on_success,
                     axis_samples=axis_samples)
    return control.Environment(physics, task, time_limit=time_limit, control_timestep=control_timestep)
