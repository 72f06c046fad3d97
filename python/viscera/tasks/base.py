"""What every bowel task shares: the physics with its named accessors, randomised episodes, the
common observations, success that lasts, and the one factory that builds any task.

A task is one module of viscera.tasks, its class registered where it is written, as dm_control's
suite registers its tasks (`@SUITE.add` in suite/cartpole.py):

    @base.register("grasp_lift", "viscera/GraspLift-v0")   # its name and gymnasium id, literals
    class GraspLift(base.BowelTask):
        CRITERION = "the marked band held 5 cm above the posterior wall for 1 s"
        TOOLS = (Tool("grasper", "grasper", "right"),)
        POLICY = GraspLiftPolicy                            # its scripted policy: POLICY(env)
        ...

    load = base.loader(GraspLift)   # optional: viscera.tasks.grasp_lift.load(seed=0, ...)

Nothing else lists it: viscera.tasks imports every module of the folder that registers a task
(viscera.task_registry finds them, and their gymnasium ids, from the source without importing it),
and `build`, the one factory, makes any task's environment (viscera.tasks.load). A task defines:
- TOOLS, its tool set (scene.Tool: name, kind, trocar), and CRITERION, its success in words;
- `condition(physics)`, the instantaneous goal; `success(physics)` is True once it has held for
  the last HOLD_S seconds of simulated time, and the episode then ends (discount 0);
- `task_observations(physics)` and `potential(physics)`, its progress towards the goal in [0, 1],
  from which every task's reward is paid by one contract (viscera.tasks.reward: the potential's
  change, a time cost and a success bonus, so that success is the return's optimum; `reward=
  "sparse"` pays success alone);
- optionally its own keyword options (its __init__'s besides BowelTask's: clear_area's
  end_on_success), POLICY, `draw(physics)`, drawing the task's own episode details after the
  bowel has settled (by default the target is placed, when the task has one), and
  `failure(physics)`, which ends an episode early (discount 0); a perforated bowel ends any
  task's episode as a failure.

One step's measurements: what the condition, the reward and the observation read of the bowel
over the target (the dense axis, the target's coverage) is `task.measurements(physics)`, a
Measurements record made anew after every control step and at every reset (dm_control's
after_step), each value computed once, when first read.

Each episode (initialize_episode, from the task's RandomState: same seed, same episode, bit for
bit) draws a settled start, tissue and tilt (scene.draw_episode) and sets them in the physics in
place: the model is compiled once, from the template episode (scene.template_episode), with its
numbers at fixed width, and each reset rewrites the bowel's config keys and the gravity and
rebuilds the plugin's caches (viscera.intestine.reconfigure), with no compile and no settling.
The episode starts from the bank's settled shape at rest, with the clock at 0; the drawn tissue
and tilt act from its first step.
"""
from __future__ import annotations

import collections
import dataclasses
import functools
import inspect
import itertools
import math
from collections.abc import Callable

import mujoco
import numpy as np
from dm_control import mujoco as dm_mujoco
from dm_control.rl import control
from dm_control.suite import base

import viscera
from viscera.checks import checked_integer
from viscera.intestine import grid_under_axis
from viscera.numerics import dot, norm
from viscera.tasks import reward as reward_module  # where a parameter is called reward
from viscera.tasks import scene
from viscera.tasks import scene as scene_module  # where a parameter is called scene

AXIS_SAMPLES = 100      # intestine axis points observed (3 cm apart on 3 m)
MAX_AXIS_SAMPLES = 100_000
GRID = 10               # target sampling points per side
JAW_OPEN_RAD = 0.2      # a jaw counts as open above this opening (rad; closed at or below 0.1)
CLEAR_MARGIN = 0.01     # m: a tool is clear of the target outside it grown by this, or above CLEAR_HEIGHT
CLEAR_HEIGHT = 0.05     # m above the posterior wall
STILL_RAD_S = 0.3       # rad/s: a tool's hinge at rest below this ...
STILL_M_S = 0.03        # m/s: ... and its slide below this
PIXEL_CAPSULES_LENGTH_M = 3.0  # m: PIXEL_CAPSULES are for this length, the box abdomen's bowel
PIXEL_CAPSULES = 160    # capsules drawing the intestine when pixels are observed (1.9 cm each on 3 m):
                        # the frame's cost is geometry; 120 showed angular bends, 512 cost 3x


class Physics(dm_mujoco.Physics):
    """The abdomen with named accessors for the tasks."""

    def intestine(self) -> viscera.Intestine:
        """The bowel the tasks work on: the scene's first intestine instance (the anatomical
        scene's small bowel; its colon is the second)."""
        model = self.model.ptr
        cached = getattr(self, "_intestine", None)
        if cached is None or cached.model is not model:  # reload_from_* replaces the model
            cached = self._intestine = viscera.intestines(model)[0]
        return cached

    def reconfigure_bowel(self, config: dict[str, str]) -> None:
        """Rewrite the bowel's config keys in place (viscera.intestine.reconfigure: values of the
        compiled width) and forget the intestine record read from the old ones."""
        gut = self.intestine()
        viscera.reconfigure(self.model.ptr, self.data.ptr, gut.instance, config)
        # the record as intestines() would read it again: only the config and the mass can change
        self._intestine = dataclasses.replace(gut, config={**gut.config, **config},
                                              mass=float(config["mass"]) if "mass" in config else gut.mass)

    def wall_height(self, x: float, y: float) -> float | None:
        """The posterior wall's height (m) at (x, y) (m) where it is a heightfield geom called
        posterior_wall (the anatomical scene's: bilinear between its samples, within a
        millimetre of MuJoCo's triangles there); None where there is none (the box abdomen's
        flat floor)."""
        model = self.model.ptr
        geom = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "posterior_wall")
        if geom < 0 or model.geom_type[geom] != mujoco.mjtGeom.mjGEOM_HFIELD:
            return None
        field = model.geom_dataid[geom]
        rows, columns = model.hfield_nrow[field], model.hfield_ncol[field]
        size = model.hfield_size[field]
        grid = model.hfield_data[model.hfield_adr[field]:model.hfield_adr[field] + rows * columns].reshape(rows, columns)
        local = np.array([x, y]) - self.data.geom_xpos[geom][:2]
        u = np.clip((local[0] + size[0]) / (2 * size[0]) * (columns - 1), 0, columns - 1)
        v = np.clip((local[1] + size[1]) / (2 * size[1]) * (rows - 1), 0, rows - 1)
        i, j = min(int(v), rows - 2), min(int(u), columns - 2)
        fv, fu = v - i, u - j
        value = ((1 - fv) * ((1 - fu) * grid[i, j] + fu * grid[i, j + 1]) +
                 fv * ((1 - fu) * grid[i + 1, j] + fu * grid[i + 1, j + 1]))
        return float(self.data.geom_xpos[geom][2] + value * size[2])

    def axis_points(self, count: int = AXIS_SAMPLES) -> np.ndarray:
        return self.intestine().axis_points(self.data.ptr, count)

    def axis_point_at(self, abscissa: float) -> np.ndarray:
        """The axis point (m) at `abscissa` m along the rest axis."""
        return self.axis_points_at(np.array([abscissa]))[0]

    def axis_points_at(self, abscissae: np.ndarray) -> np.ndarray:
        """The axis points (m, (k, 3)) at `abscissae` (m along the rest axis, (k,)), in one call."""
        gut = self.intestine()
        s = np.clip(np.asarray(abscissae, dtype=float) / gut.rest_length, 0.0, 1.0)
        return viscera.spline_points(gut.positions(self.data.ptr), s)

    # -- the target: a patch of the posterior wall (site target_area)
    def target(self) -> np.ndarray:
        """Centre (m, 3) then half sizes along x and y (m) of the target rectangle."""
        site = self.tool_index().target_site
        return np.concatenate([self.data.site_xpos[site], self.model.site_size[site][:2]])

    def target_points(self) -> np.ndarray:
        """The GRID x GRID sampling points of the target rectangle (m, world frame)."""
        site = self.tool_index().target_site
        centre, half = self.data.site_xpos[site], self.model.site_size[site][:2]
        key = (centre.tobytes(), half.tobytes())
        cached = getattr(self, "_target_points", None)
        if cached is None or cached[0] != key:  # the target moves only between episodes
            u = (np.arange(GRID) + 0.5) / GRID * 2.0 - 1.0
            self._target_grid = centre[0] + u * half[0], centre[1] + u * half[1]  # columns' x, rows' y
            x, y = np.meshgrid(*self._target_grid)
            cached = self._target_points = key, np.stack([x.ravel(), y.ravel(), np.full(GRID * GRID, centre[2])], axis=1)
        return cached[1].copy()

    def dense_axis(self) -> np.ndarray:
        """The axis at four points per collision sphere (m, (4 S, 3)): what coverage reads."""
        gut = self.intestine()
        return gut.axis_points(self.data.ptr, 4 * gut.sphere_count)

    def coverage(self, points: np.ndarray | None = None, axis: np.ndarray | None = None) -> np.ndarray:
        """1 where the tube lies over a target point (within one radius in the wall's plane);
        `points` (m, (k, 2)) instead of the target's, `axis` the dense_axis if already measured."""
        gut = self.intestine()
        if points is None:  # the target's grid
            self.target_points()
            xs, ys = self._target_grid
            if axis is None:  # in the plugin, one call: the same booleans as grid_under_tube on the dense axis
                return grid_under_axis(gut.positions(self.data.ptr), 4 * gut.sphere_count, xs, ys, gut.radius)
            return grid_under_tube(xs, ys, axis[:, :2], gut.radius).astype(float)
        axis = self.dense_axis() if axis is None else axis
        return cells_under_tube(points, axis[:, :2], gut.radius).astype(float)

    def uncovered_fraction(self) -> float:
        return float(1.0 - self.coverage().mean())

    # -- the laparoscope
    def aim_laparoscope(self, point) -> None:
        """Turn the laparoscope (camera `laparoscope` and its light) to look at `point` (m), the
        image's up towards the cranial side, as the camera assistant aims the scope at the
        working area. The pose is a model constant, not state (as the target's place)."""
        model, data = self.model.ptr, self.data.ptr
        camera = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, "laparoscope")
        if camera < 0:
            return
        # no BLAS (@, np.linalg.norm): the pose sets where the tools start, the same bits on any CPU
        body = model.cam_bodyid[camera]
        rotation = data.xmat[body].reshape(3, 3)
        position = data.xpos[body] + dot(rotation, model.cam_pos[camera])
        back = position - np.asarray(point, dtype=float)  # the camera looks along its -z
        back /= norm(back)
        up = np.array([0.0, 1.0, 0.0]) - back[1] * back
        up /= norm(up)
        world = np.stack([np.cross(up, back), up, back], axis=1)  # columns: the camera's x, y, z
        in_body = (rotation[:, :, None] * world[:, None, :]).sum(axis=0)
        mujoco.mju_mat2Quat(model.cam_quat[camera], in_body.ravel())
        for light in range(model.nlight):
            if model.light_bodyid[light] == body:
                model.light_dir[light] = -in_body[:, 2]
        mujoco.mj_kinematics(model, data)
        mujoco.mj_camlight(model, data)

    # -- the tools
    def tool_index(self) -> "ToolIndex":
        """Where the tools' names, actuators, joints, sensors and sites are in this model, found once
        per model (a reset that rebuilds the physics gets a new one)."""
        model = self.model.ptr
        cached = getattr(self, "_tool_index", None)
        if cached is None or cached.model is not model:
            cached = self._tool_index = ToolIndex(self)
        return cached

    def tools(self) -> tuple[str, ...]:
        """The scene's tools, by name, in the order of their actuators."""
        return self.tool_index().names

    def graspers(self) -> tuple[str, ...]:
        return tuple(site[:-len("_tip")] for site in self.intestine().graspers)

    def tool_forces(self) -> np.ndarray:
        return self.data.sensordata[self.tool_index().force_sensordata]

    def holding(self) -> np.ndarray:
        """1 where a grasper holds the intestine (one entry per grasper)."""
        return np.array([float(g.holding) for g in self.intestine().grasps(self.data.ptr)])

    def perforated(self) -> bool:
        """The bowel's wall is through somewhere: perforated by a pinch or torn (docs/model.md#damage)."""
        return bool(np.any(self.intestine().damage(self.data.ptr)[:, 1] > 0.0))

    def held_abscissae(self) -> np.ndarray:
        """Per grasper, the held point's abscissa (m along the rest axis), or -1 when not holding."""
        return np.array([g.abscissa if g.holding else -1.0 for g in self.intestine().grasps(self.data.ptr)])

    def tool_joints(self) -> np.ndarray:
        return self.data.qpos[self.tool_index().joint_qpos]

    def working_point(self, tool: str) -> np.ndarray:
        """Where a tool works (m): a grasper's tip site, a retractor's paddle centre."""
        kind, index = self.tool_index().working_point[tool]
        return (self.data.site_xpos if kind == "site" else self.data.geom_xpos)[index].copy()

    def jaws_open(self) -> bool:
        """Every grasper's jaw open (above JAW_OPEN_RAD) and holding nothing."""
        jaws = self.data.qpos[self.tool_index().jaw_qpos(self.graspers())]
        return bool(np.all(jaws > JAW_OPEN_RAD)) and not self.holding().any()

    def tools_still(self) -> bool:
        """Every tool joint nearly at rest (hinges under STILL_RAD_S, slides under STILL_M_S): what
        stays done does not depend on tools still moving."""
        index = self.tool_index()
        return bool(np.all(np.abs(self.data.qvel[index.joint_dof]) <= index.still_speed))

    def tool_offset(self, tool: str) -> float:
        """How far below its trocar a tool's working point is at zero depth (m)."""
        kind, index = self.tool_index().working_point[tool]
        position = self.model.site_pos[index] if kind == "site" else self.model.geom_pos[index]
        return -float(position[2])

    def tool_visible(self, tool: str, axis: np.ndarray | None = None, radius: float | None = None,
                     margin: float = 0.8) -> bool:
        """Whether the laparoscope sees `tool`'s working point: inside `margin` of its image's half
        extents and no tube (the bowel's `axis`, m, of `radius`, m) across its line of sight."""
        return self.point_visible(self.working_point(tool), axis, radius, margin)

    def tool_seen(self, tool: str, axis: np.ndarray | None = None, radius: float | None = None) -> bool:
        """Whether the laparoscope sees some of `tool`'s last SEEN_REACH_M: one of SEEN_POINTS points
        along its shaft, from the working point back, inside the image with no tube across its line
        of sight. What the score counts as visible: it agrees with the segmentation the camera
        draws (some pixel of the jaw or paddle) on 96 % of the ticks of three scripted episodes
        (tests/python/test_tasks.py), where the working point alone agrees on 74 %."""
        model, data = self.model.ptr, self.data.ptr
        camera = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, "laparoscope")
        if camera < 0:
            return True
        tip = self.working_point(tool)
        shaft = tip - self.named.data.xpos[f"{tool}_trocar"]
        shaft = shaft / math.sqrt(float((shaft * shaft).sum()))
        points = tip - np.linspace(0.0, SEEN_REACH_M, SEEN_POINTS)[:, None] * shaft  # (k, 3)
        eye, frame = data.cam_xpos[camera], data.cam_xmat[camera].reshape(3, 3)
        local = ((points - eye)[:, :, None] * frame).sum(axis=1)  # camera frame, looking along -z
        half = math.tan(math.radians(float(model.cam_fovy[camera])) / 2.0)
        inside = (local[:, 2] < 0.0) & (np.maximum(np.abs(local[:, 0]), np.abs(local[:, 1])) <= -local[:, 2] * half)
        if not inside.any():
            return False
        axis = self.dense_axis() if axis is None else axis
        radius = self.intestine().radius if radius is None else radius
        sights = points[inside] - eye  # (m, 3): all the lines of sight at once
        along = np.clip(((axis - eye)[None, :, :] * sights[:, None, :]).sum(axis=2)
                        / (sights * sights).sum(axis=1)[:, None], 0.0, 1.0)
        gap = axis[None, :, :] - (eye + along[:, :, None] * sights[:, None, :])
        return bool(((gap * gap).sum(axis=2) > radius * radius).all(axis=1).any())

    def point_visible(self, point: np.ndarray, axis: np.ndarray | None = None, radius: float | None = None,
                      margin: float = 0.8) -> bool:
        """Whether the laparoscope sees `point` (m): inside `margin` of its image's half extents and
        no tube (the bowel's `axis`, m, of `radius`, m) across its line of sight."""
        model, data = self.model.ptr, self.data.ptr
        camera = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, "laparoscope")
        if camera < 0:
            return True
        axis = self.dense_axis() if axis is None else axis
        radius = self.intestine().radius if radius is None else radius
        eye, frame = data.cam_xpos[camera], data.cam_xmat[camera].reshape(3, 3)
        local = ((point - eye)[:, None] * frame).sum(axis=0)  # camera frame: x right, y up, looking along -z
        if local[2] >= 0.0:
            return False
        half = math.tan(math.radians(float(model.cam_fovy[camera])) / 2.0)  # fovy is vertical
        if max(abs(local[0]), abs(local[1])) / -local[2] > margin * half:  # inside a square image, the narrowest
            return False
        sight = point - eye
        length2 = float((sight * sight).sum())
        along = np.clip(((axis - eye) * sight).sum(axis=1) / length2, 0.0, 1.0)
        gap = axis - (eye + along[:, None] * sight)
        return bool(((gap * gap).sum(axis=1) > radius * radius).all())

    def tools_clear_of_target(self) -> bool:
        """No tool's working point over the target (grown by CLEAR_MARGIN) below CLEAR_HEIGHT."""
        target = self.target()
        centre, half = target[:3], target[3:] + CLEAR_MARGIN
        for tool in self.tools():
            point = self.working_point(tool)
            if np.all(np.abs(point[:2] - centre[:2]) <= half) and point[2] - centre[2] < CLEAR_HEIGHT:
                return False
        return True


class ToolIndex:
    """The tools of one compiled model, by index: what the tasks read every step without looking
    names up (Physics.tool_index)."""

    def __init__(self, physics: Physics):
        model = physics.model
        self.model = model.ptr
        names: list[str] = []
        for i in range(model.nu):
            tool = model.id2name(i, "actuator").rsplit("_", 1)[0]
            if tool not in names:
                names.append(tool)
        self.names = tuple(names)
        tools = set(names)
        sensors = [mujoco.mj_name2id(model.ptr, mujoco.mjtObj.mjOBJ_SENSOR, f"{tool}_force") for tool in names]
        self.force_sensordata = np.concatenate(
            [np.arange(model.sensor_adr[i], model.sensor_adr[i] + model.sensor_dim[i]) for i in sensors]
        ) if sensors else np.zeros(0, dtype=int)
        joints = [j for j in range(model.njnt) if model.id2name(j, "joint").rsplit("_", 1)[0] in tools]
        self.joint_names = {model.id2name(j, "joint"): j for j in joints}
        self.joint_qpos = np.array([model.jnt_qposadr[j] for j in joints], dtype=int)
        self.joint_dof = np.array([model.jnt_dofadr[j] for j in joints], dtype=int)
        self.still_speed = np.array([STILL_M_S if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_SLIDE else STILL_RAD_S
                                     for j in joints])
        self.working_point = {}
        for tool in names:
            site = mujoco.mj_name2id(model.ptr, mujoco.mjtObj.mjOBJ_SITE, f"{tool}_tip")
            self.working_point[tool] = ("site", site) if site >= 0 else (
                "geom", mujoco.mj_name2id(model.ptr, mujoco.mjtObj.mjOBJ_GEOM, f"{tool}_paddle"))
        self._jaws: dict[tuple[str, ...], np.ndarray] = {}
        self.target_site = mujoco.mj_name2id(model.ptr, mujoco.mjtObj.mjOBJ_SITE, "target_area")

    def jaw_qpos(self, graspers: tuple[str, ...]) -> np.ndarray:
        if graspers not in self._jaws:
            self._jaws[graspers] = np.array(
                [self.model.jnt_qposadr[self.joint_names[f"{g}_jaw"]] for g in graspers], dtype=int)
        return self._jaws[graspers]


def grid_under_tube(xs: np.ndarray, ys: np.ndarray, axis: np.ndarray, radius: float) -> np.ndarray:
    """cells_under_tube of the grid of cells (xs[i], ys[j]) (m; in meshgrid's order, y major), the
    same booleans from the same sums: the squares of the x and y offsets are each computed once
    per column and row, not once per cell."""
    low = np.array([xs.min(), ys.min()]) - radius
    high = np.array([xs.max(), ys.max()]) + radius
    x, y = axis[:, 0], axis[:, 1]
    near = axis[(x >= low[0]) & (x <= high[0]) & (y >= low[1]) & (y <= high[1])]  # the rest cannot cover
    if not len(near):
        return np.zeros(len(xs) * len(ys), dtype=bool)
    dx = xs[:, None] - near[None, :, 0]
    dy = ys[:, None] - near[None, :, 1]
    squared = (dy * dy)[:, None, :] + (dx * dx)[None, :, :]  # [row, column, axis point]: dx^2 + dy^2
    return (squared.min(axis=2) <= radius ** 2).ravel()


def cells_under_tube(cells: np.ndarray, axis: np.ndarray, radius: float) -> np.ndarray:
    """Which `cells` (m, (m, 2)) a tube of `radius` (m) lies over: an `axis` point (m, (n, 2))
    within the radius of the cell in the wall's plane."""
    low, high = cells.min(axis=0) - radius, cells.max(axis=0) + radius
    x, y = axis[:, 0], axis[:, 1]
    near = axis[(x >= low[0]) & (x <= high[0]) & (y >= low[1]) & (y <= high[1])]  # the rest cannot cover
    if not len(near):
        return np.zeros(len(cells), dtype=bool)
    dx = cells[:, 0, None] - near[None, :, 0]
    dy = cells[:, 1, None] - near[None, :, 1]
    return (dx * dx + dy * dy).min(axis=1) <= radius ** 2


class Measurements:
    """What one state of the physics gives its step's condition, reward and observation, each
    value computed once, when first read (BowelTask.measurements): a record is of one MjData at
    one time, so that it is never read for another state."""

    def __init__(self, physics: Physics):
        self.physics = physics
        self.data, self.time = physics.data.ptr, float(physics.data.time)
        self._memo: dict = {}

    def memo(self, key: str, measure: Callable):
        """A task's own measurement of this state: `measure()` the first time `key` is asked for."""
        if key not in self._memo:
            self._memo[key] = measure()
        return self._memo[key]

    def of(self, physics: Physics) -> bool:
        """Whether this is the record of `physics` as it is now (its MjData, at its time)."""
        return physics.data.ptr is self.data and float(physics.data.time) == self.time

    @functools.cached_property
    def dense_axis(self) -> np.ndarray:
        """The axis at four points per collision sphere (m, (4 S, 3)): Physics.dense_axis."""
        return self.physics.dense_axis()

    @functools.cached_property
    def coverage(self) -> np.ndarray:
        """The target's GRID x GRID points, 1 where the tube lies over one: Physics.coverage (from
        the dense axis if it was read, else in the plugin without it)."""
        return self.physics.coverage(axis=self.__dict__.get("dense_axis"))

    @functools.cached_property
    def uncovered_fraction(self) -> float:
        return float(1.0 - self.coverage.mean())


SUITE: dict[str, type[BowelTask]] = {}  # task name -> its class, filled as the task modules are imported


def register(name: str, env_id: str) -> Callable[[type[BowelTask]], type[BowelTask]]:
    """Class decorator: the task called `name` (viscera.tasks.load(name)), with gymnasium id
    `env_id` (viscera/Name-vN). viscera.task_registry reads both from the source, so write them
    as string literals."""
    def add(task: type[BowelTask]) -> type[BowelTask]:
        if SUITE.get(name, task) is not task:
            raise ValueError(f"task {name!r} is registered twice: {SUITE[name].__module__}.{SUITE[name].__qualname__} "
                             f"and {task.__module__}.{task.__qualname__}")
        task.NAME, task.ENV_ID = name, env_id
        SUITE[name] = task
        return task
    return add


class BowelTask(base.Task):
    """A task on the randomised abdomen; see the module doc."""

    NAME = ""             # its name and gymnasium id: set by register
    ENV_ID = ""
    CRITERION = "the task’s goal"  # its success in a few words (the verdict line of play, record and replay)
    POLICY: Callable | None = None  # its scripted policy: POLICY(env) is a callable time_step -> action

    TOOLS: tuple[scene.Tool, ...] = ()
    # The tools' top speeds, per second in each coordinate's unit (rad, m): each actuator's target
    # moves toward the action at most this fast, as a hand or a robot moves a laparoscopic tool
    # (tip speeds up to about 0.3 m/s). An action far from the tool is reached smoothly instead of
    # in one jump: uniform random actions once drove a depth slide at 10 m/s through the bowel
    # and the posterior wall. 1.25 times the scripted policies' planning limits (policies.LIMITS),
    # so their moves never meet them; the jaws close at any speed (they do not push the bowel).
    TOOL_SPEED = {"pitch": np.radians(75.0), "yaw": np.radians(75.0), "depth": 0.1875, "roll": np.radians(112.5),
                  "jaw": np.inf}
    HOLD_S = 0.0          # s the condition must hold for success
    TIME_LIMIT_S = 20.0   # s, the default episode length

    def __init__(self, random=None, axis_samples: int = AXIS_SAMPLES, randomize: bool = True,
                 scene: str = scene.DEFAULT_SCENE):
        super().__init__(random=random)
        self.scene = scene_module.scene_named(scene)  # the cavity (scene.SCENES): "abdomen" or "anatomical"
        self.axis_samples = axis_samples
        self.randomize = randomize
        self.episode: scene.Episode | None = None
        self._held_since: float | None = None
        self._failed = False
        self.camera = None  # viscera.pixels.Camera when pixels are observed
        self._measured: Measurements | None = None  # the last state's (measurements)
        self.control_timestep_s = 0.02  # s, the environment's (build sets it)
        self._tool_speeds: np.ndarray | None = None
        self.reward_kind = reward_module.DEFAULT_KIND  # "dense" or "sparse" (build sets it)
        self.contract = reward_module.Contract.of(self.TIME_LIMIT_S, self.TIME_LIMIT_S, self.control_timestep_s)
        self._potential: float | None = None  # the last state's, None before an episode's first step
        self._steps = 0                        # control steps taken this episode
        self._rewarded_success = False         # the success bonus is paid once an episode
        self._reward: float | None = None      # the last step's (after_step computes it)

    def reseed(self, seed: int | None) -> None:
        """Draw the next episodes as a task built with `seed` would (numpy's RandomState(seed)):
        for an environment reused with another seed (viscera.tasks.reseed, gymnasium's reset)."""
        self._random = np.random.RandomState(seed)  # dm_control's Task keeps its `random` there

    def scripted_policy(self, env) -> Callable:
        """This task's scripted closed-loop policy for `env`: a callable time_step -> action."""
        if self.POLICY is None:
            raise NotImplementedError(f"task {self.NAME!r} has no scripted policy")
        return self.POLICY(env)

    def before_step(self, action, physics: Physics) -> None:
        """The actuators' targets move toward `action` at the tools' top speeds (TOOL_SPEED)."""
        action = np.asarray(getattr(action, "continuous_actions", action), dtype=float)
        if self._tool_speeds is None or len(self._tool_speeds) != physics.model.nu:  # the task's tools are fixed
            self._tool_speeds = self.tool_speeds(physics)
        reach = self._tool_speeds * self.control_timestep_s
        current = physics.data.ctrl
        physics.set_control(np.minimum(np.maximum(action, current - reach), current + reach))  # np.clip, cheaper

    def tool_speeds(self, physics: Physics) -> np.ndarray:
        """Each actuator's top speed (TOOL_SPEED by its coordinate, the name's last part)."""
        names = [physics.model.id2name(i, "actuator") for i in range(physics.model.nu)]
        return np.array([self.TOOL_SPEED.get(name.rsplit("_", 1)[-1], np.inf) for name in names])

    def measurements(self, physics: Physics) -> Measurements:
        """The measurements of `physics` as it is now, which the condition, the reward and the
        observation share: the record after_step made after this control step or reset, or a new
        one for a state no step made (dm_control's observation_spec observes before a reset)."""
        if self._measured is None or not self._measured.of(physics):
            self._measured = Measurements(physics)
        return self._measured

    @property
    def failed(self) -> bool:
        """The episode has failed (`failure` held after some step): it ended, or ends, without success."""
        return self._failed

    # -- the scene
    TARGET_HALF_M = (0.02, 0.015)  # the target patch's half sizes in randomised episodes (4 x 3 cm)
    HAS_TARGET = True              # the task works on the target patch (else it is not drawn)

    def scene_xml(self, episode: scene.Episode | None, target=None) -> str:
        config = self.intestine_config()
        if self.camera is not None:
            # the same 1.9 cm capsules at any length: 160 on the abdomen's 3 m, 270 on 5.06 m
            length = scene.bowel_length(self.scene.name)
            config = dict(config, draw_capsules=str(int(round(PIXEL_CAPSULES * length / PIXEL_CAPSULES_LENGTH_M))))
        return scene.compose(self.TOOLS, episode, target, config, self.TARGET_HALF_M, show_target=self.HAS_TARGET,
                             scene=self.scene.name)

    def intestine_config(self) -> dict[str, str]:
        """Extra intestine config keys of this task (e.g. a marked band)."""
        return {}

    def observe_pixels(self, physics: Physics, camera) -> None:
        """Add `camera`'s frames (viscera.pixels.Camera) to the observations, the intestine drawn
        as PIXEL_CAPSULES capsules per PIXEL_CAPSULES_LENGTH_M of it; the physics is rebuilt for it
        (as every reset does)."""
        if camera.camera not in physics.named.model.cam_fovy.axes.row.names:
            raise ValueError(f"camera = {camera.camera!r}: the task's scene has no such camera; it has "
                             f"{list(physics.named.model.cam_fovy.axes.row.names)}")
        self.camera = camera
        physics.reload_from_xml_string(self.model_xml())

    def initialize_episode(self, physics: Physics) -> None:
        self.episode = scene.draw_episode(self.random, scene=self.scene.name) if self.randomize else None
        self._held_since = None
        self._failed = False
        self._potential, self._steps, self._rewarded_success, self._reward = None, 0, False, None
        self.prepare(physics)
        super().initialize_episode(physics)  # dm_control's: calls after_step

    def prepare(self, physics: Physics) -> None:
        """Set this episode in the physics in place (start_episode), the task's own details drawn
        on its start (the marked band, a model value, set with the rest), then aim the
        laparoscope and ready the tools."""
        if not self.randomize:
            return  # the shipped scene, as built; dm_control's reset_context has reset it
        self.start_episode(physics)
        physics.aim_laparoscope(self.view_point(physics))
        self.ready_tools(physics)

    def model_xml(self) -> str:
        """The MJCF the physics is compiled from, once: the template episode's (scene.template_episode)
        at fixed width when episodes are randomised, each reset then setting its own in place; the
        shipped scene's otherwise."""
        return self.scene_xml(scene.template_episode(self.scene.name) if self.randomize else None)

    def start_episode(self, physics: Physics) -> None:
        """This episode in place: its gravity (model.opt); its start, read by the task's `draw`;
        the bowel's start, tissue and task keys (the marked band) and the other intestines'
        starts, config keys rewritten in the compiled model (viscera.intestine.reconfigure); then
        MuJoCo's reset: the bank's settled start at rest, the tools withdrawn, the clock at 0. No
        compile and no settling: the drawn tissue and tilt act from the episode's first step."""
        model, data = physics.model.ptr, physics.data.ptr
        model.opt.gravity[:] = self.episode.gravity
        gut = physics.intestine()
        state = data.plugin_state[model.plugin_stateadr[gut.instance]:]
        state[gut.layout["positions"]] = self.episode.control_points.ravel()  # what draw reads: the start
        self.draw(physics)
        physics.reconfigure_bowel({**scene.episode_config(self.episode, gut.rest_length), **self.intestine_config()})
        for name, points in self.episode.others.items():
            instance = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_PLUGIN, name)
            viscera.reconfigure(model, data, instance, {"points": viscera.fixed_width_numbers(points)})
        mujoco.mj_resetData(model, data)
        mujoco.mj_forward(model, data)

    def ready_tools(self, physics: Physics) -> None:
        """Every tool at a working depth in the laparoscope's view, as trainers start, its jaws
        open, held there by its actuators (ctrl = qpos), at rest. Its working point is put on a
        line of sight of the camera, READY_CLEARANCE_M above the bowel's top below it: of the
        image points READY_IMAGE_POINTS (its own side of the image first), the first whose spot
        the tool reaches from its trocar (shaft within REACH_DEG, depth in range) and that the
        camera sees (Physics.tool_visible); the tool stays withdrawn if none does."""
        model, data = physics.model.ptr, physics.data.ptr
        camera = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, "laparoscope")
        if camera < 0:
            return
        axis = physics.dense_axis()
        radius = physics.intestine().radius
        # every intestine of the scene, each with its widest radius, keeps the tools clear (the
        # anatomical abdomen's colon lies over the small bowel's edges)
        tubes = [(gut.axis_points(data, 4 * gut.sphere_count), max(gut.radius, gut.radius_end))
                 for gut in viscera.intestines(model)]
        index = physics.tool_index()
        eye, frame = data.cam_xpos[camera].copy(), data.cam_xmat[camera].reshape(3, 3).copy()
        half = math.tan(math.radians(float(model.cam_fovy[camera])) / 2.0)
        taken: list[np.ndarray] = []
        for tool in physics.tools():
            trocar = physics.named.model.body_pos[f"{tool}_trocar"].copy()
            offset = physics.tool_offset(tool)
            side = 1.0 if trocar[0] >= 0.0 else -1.0
            for (u, v), clearance in itertools.product(READY_IMAGE_POINTS, (READY_CLEARANCE_M, READY_CLEARANCE_M / 2)):
                ray = (frame * np.array([side * u * half, v * half, -1.0])).sum(axis=1)
                ray /= math.sqrt(float((ray * ray).sum()))
                spots = [spot_on_ray(eye, ray, tube, tube_radius + clearance) for tube, tube_radius in tubes]
                point = None if any(spot is None for spot in spots) else min(
                    spots, key=lambda spot: float(((spot - eye) ** 2).sum()))
                if point is None or any(float(((point - other) ** 2).sum()) < READY_APART_M ** 2 for other in taken):
                    continue
                pose = tool_pose(trocar, point, offset)
                if pose is None or pose["depth"] < READY_MIN_DEPTH_M:
                    continue
                self._set_tool(physics, index, tool, pose)
                if physics.tool_visible(tool, axis, radius):
                    taken.append(point)
                    break
            else:
                self._set_tool(physics, index, tool, {"pitch": 0.0, "yaw": 0.0, "depth": 0.0, "roll": 0.0, "jaw": 0.0})

    def _set_tool(self, physics: Physics, index: "ToolIndex", tool: str, pose: dict[str, float]) -> None:
        model, data = physics.model.ptr, physics.data.ptr
        for coordinate, value in pose.items():
            joint = index.joint_names.get(f"{tool}_{coordinate}")
            if joint is None:
                continue
            if coordinate == "jaw":
                value = float(model.actuator(f"{tool}_jaw").ctrlrange[1])  # open
            data.qpos[model.jnt_qposadr[joint]] = value
            data.qvel[model.jnt_dofadr[joint]] = 0.0
            data.ctrl[model.actuator(f"{tool}_{coordinate}").id] = value
        mujoco.mj_forward(model, data)

    def view_point(self, physics: Physics) -> np.ndarray:
        """Where the laparoscope looks this episode (m): the target's centre; a task without one
        names its own working point."""
        return physics.target()[:3]

    def draw(self, physics: Physics) -> None:
        """The task's own random details, on the settled bowel (default: the target placed, when
        the task has one). Not called when the episodes are not randomised."""
        if self.HAS_TARGET:
            self.move_target(physics)

    def move_target(self, physics: Physics) -> None:
        """Place the target where the settled bowel covers it (scene.place_target); the site is
        moved in place (a model constant, not state), so the bowel does not move."""
        half = physics.named.model.site_size["target_area"][:2]
        u = (np.arange(GRID) + 0.5) / GRID * 2.0 - 1.0
        offsets = np.stack(np.meshgrid(u * half[0], u * half[1]), axis=-1).reshape(-1, 2)

        axis = physics.dense_axis()  # the bowel stays: one axis for every place tried
        radius = physics.intestine().radius

        def coverage_at(x: float, y: float) -> float:
            return float(physics.coverage(offsets + np.array([x, y]), axis=axis).mean())

        def loops_at(x: float, y: float) -> int:
            over = np.all(np.abs(axis[:, :2] - (x, y)) <= half + radius, axis=1)
            return int(np.count_nonzero(np.diff(over.astype(int)) == 1) + over[0])

        x, y = scene.place_target(self.random, coverage_at, loops_at, region=self.scene.target_region)
        physics.named.model.site_pos["target_area"][:2] = (x, y)
        wall = physics.wall_height(x, y)
        if wall is not None:  # a curved wall: the patch on it, as on the box's flat floor
            physics.named.model.site_pos["target_area"][2] = wall + physics.named.model.site_size["target_area"][2]
        mujoco.mj_kinematics(physics.model.ptr, physics.data.ptr)

    # -- success that lasts
    def condition(self, physics: Physics) -> bool:
        raise NotImplementedError

    def failure(self, physics: Physics) -> bool:
        """An episode that can no longer succeed (default: never)."""
        return False

    def potential(self, physics: Physics) -> float:
        """The task's progress towards its goal, in [0, 1] (the dense reward is its change; default:
        1 while the condition holds, else 0)."""
        return float(self.condition(physics))

    def after_step(self, physics: Physics) -> None:
        """After every control step and at every reset: this state's measurements, then whether
        the condition holds (and since when) and whether the episode failed, then the step's reward."""
        self._measured = Measurements(physics)
        if self.condition(physics):
            if self._held_since is None:
                self._held_since = float(physics.data.time)
        else:
            self._held_since = None
        # a perforated bowel ends any task's episode as a failure (docs/model.md#damage)
        self._failed = self._failed or self.failure(physics) or physics.perforated()
        self._reward = self._step_reward(physics)

    def _step_reward(self, physics: Physics) -> float | None:
        """The reward of the control step that led to this state (viscera.tasks.reward), or None
        at a reset, where the potential of the start is measured."""
        dense = self.reward_kind == "dense"
        if self._potential is None:  # the reset's after_step
            self._potential = self.potential(physics) if dense else 0.0
            return None
        self._steps += 1
        succeeded = not self._rewarded_success and self.success(physics)
        self._rewarded_success = self._rewarded_success or succeeded
        if not dense:
            return 1.0 if succeeded else 0.0
        before = self._potential
        if succeeded:
            self._potential = self.contract.potential[1]
            return self.contract.success(before)
        self._potential = min(max(self.potential(physics), 0.0), 1.0)
        if self._failed:
            return self.contract.failure(before, self._potential, self._steps)
        return self.contract.step(before, self._potential)

    @property
    def last_potential(self) -> float | None:
        """Phi of the last state after_step measured, in [0, 1] (the goal's after a success); None
        before an episode, 0 with a sparse reward. A learner that discounts by gamma shapes with it
        in the potential-based form, gamma Phi(s') - Phi(s) (rl_grasp_lift.py)."""
        return self._potential

    def get_reward(self, physics: Physics) -> float:
        """The last control step's reward (after_step computes it, once a step: viscera.tasks.reward)."""
        return 0.0 if self._reward is None else self._reward

    def success(self, physics: Physics) -> bool:
        """The goal has held for the last HOLD_S s of simulated time."""
        return self._held_since is not None and physics.data.time - self._held_since >= self.HOLD_S - 1e-9

    def get_termination(self, physics: Physics):
        return 0.0 if self.success(physics) or self._failed else None

    # -- observations
    def get_observation(self, physics: Physics) -> collections.OrderedDict:
        observation = collections.OrderedDict()
        observation["tool_joints"] = physics.tool_joints()
        # what each actuator was last commanded (rad, m, actuator order): where the tools are going,
        # which a policy that decides from the observation alone (viscera.tasks.oracle) moves on from
        observation["tool_command"] = physics.data.ctrl.copy()
        observation["tool_forces"] = physics.tool_forces()
        observation["grasper_holding"] = physics.holding()
        observation["intestine_axis"] = physics.axis_points(self.axis_samples).ravel()
        observation["gravity"] = physics.model.opt.gravity.copy()  # m/s^2: the table's tilt
        observation.update(self.task_observations(physics))
        if self.camera is not None:
            observation["camera_pose"] = self.camera_pose(physics, self.camera.camera)
            observation.update(self.camera.render(physics))
        return observation

    @staticmethod
    def camera_pose(physics: Physics, name: str) -> np.ndarray:
        """Where the camera `name` is and where it looks (m, world; its line of sight as a unit
        vector): what the scope's holder knows of the view, observed with its pixels."""
        camera = physics.named.model.cam_fovy.axes.row.names.index(name)
        frame = physics.data.cam_xmat[camera].reshape(3, 3)
        return np.concatenate([physics.data.cam_xpos[camera], -frame[:, 2]])

    def task_observations(self, physics: Physics) -> dict:
        return {}


REACH_DEG = 55.0  # a tool reaches a point when its shaft, pointed at it, leans at most this much
SEEN_REACH_M = 0.02  # a tool is seen where some of its last 2 cm is (Physics.tool_seen) ...
SEEN_POINTS = 3      # ... tested at its working point and 1 and 2 cm back
READY_CLEARANCE_M = 0.04  # a tool's start: its working point this far above the bowel (m) ...
READY_MIN_DEPTH_M = 0.03  # ... at least this far in (m) ...
READY_APART_M = 0.03      # ... and this far from the other tools' (m)
# where in the image a tool's working point may start (x, y in fractions of the image's half
# height; x towards the tool's own side): a grid, nearest the lower outer part first
READY_IMAGE_POINTS = tuple(sorted(((u / 100.0, v / 100.0) for u in range(-30, 75, 15) for v in range(-60, 61, 20)),
                                  key=lambda p: (p[0] - 0.45) ** 2 + (p[1] + 0.25) ** 2))
MAX_DEPTH_M = 0.22        # the tools' insertion range (the depth actuators' ctrlrange)


def spot_on_ray(eye, ray, axis: np.ndarray, clearance: float, step: float = 0.005, reach: float = 0.4):
    """The farthest point (m) along the line of sight from `eye` (m) in unit direction `ray` that is
    still `clearance` (m) above the bowel's axis (`axis`, m) within that clearance horizontally,
    and every point before it too; None if the line meets the bowel, or the floor, sooner than 5 cm."""
    points = eye + (0.05 + step * np.arange(int(reach / step)))[:, None] * ray  # (k, 3)
    low, high = points[:, :2].min(axis=0) - clearance, points[:, :2].max(axis=0) + clearance
    axis = axis[np.all((axis[:, :2] >= low) & (axis[:, :2] <= high), axis=1)]  # the rest is never within clearance
    dx = points[:, 0, None] - axis[None, :, 0]
    dy = points[:, 1, None] - axis[None, :, 1]
    tops = np.where(dx * dx + dy * dy < clearance * clearance, axis[None, :, 2], -np.inf).max(axis=1, initial=-np.inf)
    blocked = (points[:, 2] < clearance) | (tops > points[:, 2] - clearance)
    first = int(np.argmax(blocked)) if blocked.any() else len(points)
    return points[first - 1] if first > 0 else None


def tool_pose(trocar, point, tip_offset: float) -> dict[str, float] | None:
    """The joint values (rad, m) that point a tool's shaft from `trocar` (m) at `point` (m) with its
    working point there (`tip_offset` m below the trocar at zero depth): pitch about x, then yaw
    about y, as the scripted policies aim; None where the shaft would lean more than REACH_DEG
    about either axis or the depth leave its range."""
    d = np.asarray(point, dtype=float) - np.asarray(trocar, dtype=float)
    distance = math.sqrt(float((d * d).sum()))
    if distance <= tip_offset or not shaft_within_reach(trocar, point):
        return None
    u = d / distance
    depth = distance - tip_offset
    if depth > MAX_DEPTH_M:
        return None
    return {"pitch": math.atan2(float(u[1]), float(-u[2])), "yaw": math.asin(min(1.0, max(-1.0, float(-u[0])))),
            "depth": depth, "roll": 0.0, "jaw": 0.0}


def within_reach(physics: Physics, tool: str, point) -> bool:
    """Whether the shaft of `tool`, pointed from its trocar at `point` (m), leans at most
    REACH_DEG from vertical about both of its pivot axes (the joints stop at 60)."""
    return shaft_within_reach(physics.named.model.body_pos[f"{tool}_trocar"], point)


def shaft_within_reach(trocar, point) -> bool:
    """Whether a shaft from `trocar` (m) pointed at `point` (m) leans at most REACH_DEG from
    vertical about both pivot axes."""
    d = np.asarray(point, dtype=float) - np.asarray(trocar, dtype=float)
    u = d / math.sqrt(float((d * d).sum()))  # math, not numpy's SIMD kernels: the same bits on any CPU
    pitch = math.degrees(math.atan2(float(u[1]), float(-u[2])))
    yaw = math.degrees(math.asin(min(1.0, max(-1.0, float(-u[0])))))
    return abs(pitch) <= REACH_DEG and abs(yaw) <= REACH_DEG


def checked_axis_samples(axis_samples: int) -> int:
    axis_samples = checked_integer("axis_samples", axis_samples, 2)
    if axis_samples > MAX_AXIS_SAMPLES:
        raise ValueError(f"axis_samples = {axis_samples}: must be at most {MAX_AXIS_SAMPLES}")
    return axis_samples


class Environment(control.Environment):
    """dm_control's control.Environment, with the episode's length public (a policy that plans to
    the end of the episode reads it)."""

    @property
    def time_limit_s(self) -> float:
        """The episode's length (s): dm_control's step limit times the control timestep (inf: none)."""
        return float(self._step_limit) * self.control_timestep()


BUILD_OPTIONS = ("time_limit", "control_timestep", "axis_samples", "randomize", "scene", "reward")  # every task's, besides its own


def own_options(task_class: type[BowelTask]) -> tuple[str, ...]:
    """The keyword options a task class adds to BowelTask's (its __init__'s other parameters)."""
    shared = set(inspect.signature(BowelTask.__init__).parameters)
    return tuple(name for name in inspect.signature(task_class.__init__).parameters if name not in shared)


def build(task_class: type[BowelTask], seed: int | None = None, time_limit: float | None = None,
          control_timestep: float = 0.02, axis_samples: int | None = None, randomize: bool = True,
          scene: str = scene_module.DEFAULT_SCENE, reward: str = reward_module.DEFAULT_KIND,
          **options) -> Environment:
    """The environment of any task class, the one factory (viscera.tasks.load): its episodes drawn
    from numpy's RandomState(seed); time_limit in s (default the task's TIME_LIMIT_S),
    control_timestep in s; axis_samples, the intestine axis points observed (None: the scene's,
    3 cm apart: 100 on the abdomen's 3 m, 170 on the anatomical 5.06 m); randomize False:
    every episode the shipped scene's bowel, tissue, tilt and target; scene, the cavity
    (viscera.tasks.scene.SCENES: "abdomen", the default, or "anatomical"); reward, "dense" (the
    default: the potential's change, a time cost and a success bonus) or "sparse" (1 on success,
    else 0), viscera.tasks.reward. `options` are the task's
    own (its __init__'s keywords besides BowelTask's: clear_area's end_on_success). The physics
    is built from the shipped scene with the task's tools; every reset rebuilds it for its episode."""
    own = own_options(task_class)
    reward = reward_module.checked_kind(reward)
    for name in options:
        if name not in own:
            raise TypeError(f"load() got an unexpected keyword argument {name!r}")
    if axis_samples is None:  # the scene's: 3 cm apart
        axis_samples = scene_module.scene_named(scene).axis_samples
    task = task_class(random=np.random.RandomState(seed), axis_samples=checked_axis_samples(axis_samples),
                      randomize=randomize, scene=scene, **options)
    task.control_timestep_s = control_timestep
    time_limit = task.TIME_LIMIT_S if time_limit is None else time_limit
    task.reward_kind = reward
    physics = Physics.from_xml_string(task.model_xml())
    env = Environment(physics, task, time_limit=time_limit, control_timestep=control_timestep)
    task.contract = reward_module.Contract.of(task.TIME_LIMIT_S, time_limit, control_timestep)
    return env


def loader(task_class: type[BowelTask]) -> Callable[..., Environment]:
    """A task module's `load(seed=None, **options)`: build(task_class, ...), which is
    viscera.tasks.load(name, ...) without pixels."""
    def load(seed: int | None = None, **options) -> Environment:
        return build(task_class, seed, **options)
    load.__doc__ = (f"The {task_class.NAME} environment: viscera.tasks.load({task_class.NAME!r}, seed, **options) "
                    f"without pixels; options: {', '.join(BUILD_OPTIONS + own_options(task_class))}.")
    return load
