"""A person in the loop: a task stepped at wall-clock rate, its tools driven by a device.

    device = viscera.teleop.devices.KeyboardDevice()
    session = Session("clear_area", seed=0, device=device)
    result = session.run()            # real time; ends on success, failure or the time limit
    result.score, result.recording    # viscera.assess's score; the replayable recording

Each control tick (control_timestep_s, 10 ms by default: 5 physics steps of the abdomen) the
session asks the device for each tool's target, moves the tool's command towards it no faster
than the scripted trajectories' velocity limits (viscera.trajectory.DEFAULT_MAX_VELOCITY),
steps the dm_control environment with that command as its action, records the action (so the
episode replays bit for bit: viscera.recording), samples the score's trace, and hands the
device a Snapshot of the tools (a haptic device renders forces from it).

The laparoscope (viscera.laparoscope) is steered too: with `camera="steer"` (the default) it is
one more tool in the device's list, named `laparoscope`, driven by the same controls in pitch,
yaw, depth and roll (its jaw does nothing), at the scope's own speeds (laparoscope.SPEED); with
`camera="follow"` an assistant keeps the active tool's working point centred; with "fixed" it
stays where the episode aimed it. `optics_deg` is 0 or 30. The pose of every tick is recorded
with its action, and set before the tick's step, so the replay sees what the person saw.

The simulation never runs faster than the wall clock. A tick that ends after its wall-clock
deadline is counted as behind (`ticks_behind`), and the time lost is dropped (`lost_s`), not
caught up by running faster afterwards.
"""

from __future__ import annotations

import contextlib
import dataclasses
import time
from collections.abc import Callable

import numpy as np

import viscera.tasks
from viscera import assess, laparoscope
from viscera.tasks.policies import Tools
from viscera.teleop.devices import MAX_VELOCITY, Device, Snapshot, ToolInfo
from viscera.trajectory import TO_SI as _TO_SI

CONTROL_TIMESTEP_S = 0.01   # a device's commands reach the tools at 100 Hz (the physics runs at 500 Hz)
FRAME_S = 1.0 / 30.0        # the viewer is redrawn at 30 frames per wall second
CAMERA_MODES = ("steer", "follow", "fixed")
CAMERA_TOOL = "laparoscope"  # the steered scope's name among the device's tools
TO_SI = np.array(_TO_SI)    # user units (viscera.trajectory.UNITS) -> rad, m


@dataclasses.dataclass
class SessionResult:
    ended: str                  # "success", "failure", "time limit", "duration", "window closed", "interrupted"
    success: bool
    simulated_s: float
    ticks: int
    ticks_behind: int           # ticks that ended after their wall-clock deadline
    lost_s: float               # wall time dropped to never run faster than real time (s)
    recording: object | None    # viscera.recording.Recording
    score: dict | None          # viscera.assess's score


class Session:
    """A task with its tools handed to `device` (see the module doc)."""

    def __init__(self, task: str, seed: int | None = None, device: Device | None = None,
                 control_timestep_s: float = CONTROL_TIMESTEP_S, time_limit_s: float | None = None,
                 record: bool = True, scene: str = "abdomen", camera: str = "steer", optics_deg: float = 0.0):
        if task not in viscera.tasks.ALL:
            raise KeyError(f"unknown task {task!r}; known: {', '.join(viscera.tasks.ALL)}")
        if camera not in CAMERA_MODES:
            raise ValueError(f"camera = {camera!r}: must be one of {', '.join(CAMERA_MODES)}")
        self.task_name, self.seed = task, seed
        self.env = viscera.tasks.load(task, seed=seed, control_timestep=control_timestep_s, time_limit=time_limit_s,
                                      scene=scene)
        self.time_step = self.env.reset()
        self.physics = self.env.physics
        self.model, self.data = self.physics.model.ptr, self.physics.data.ptr
        self.control_timestep_s = float(self.env.control_timestep())
        self.time_limit_s = float(self.env.task.TIME_LIMIT_S if time_limit_s is None else time_limit_s)
        self.device = device
        self._find_tools()
        self.command = {tool.name: tool.initial.copy() for tool in self.tools}
        self.camera_mode = camera
        self.scope = laparoscope.Laparoscope.of(self.physics, optics_deg) if camera != "fixed" else None
        self.camera_pose = self.scope.initial.copy() if self.scope is not None else None
        self._applied = None  # the pose last written into the model
        self.ticks = 0
        self.ticks_behind = 0
        self.lost_s = 0.0
        self.recorder = None
        self.hold_force_time: dict[str, float] = {}  # N s, each grasper's current hold (0 when not holding)
        self.tracer = assess.Tracer(self.env)
        self.tracer.sample(self.env)
        if record:
            from viscera.recording import Recorder
            self.recorder = Recorder(task, seed, f"person:{device.name if device else 'none'}",
                                     self.control_timestep_s, self.time_limit_s, scene=scene)
            self.recorder.recording.optics_deg = float(optics_deg)
        if device is not None:
            device.start(self.device_tools())
            device.feedback(self.snapshot())

    def device_tools(self) -> list[ToolInfo]:
        """The tools the device drives: the task's, then the laparoscope when it is steered by hand."""
        if self.camera_mode != "steer" or self.scope is None:
            return list(self.tools)
        pose = np.append(self.scope.initial, 0.0)
        return list(self.tools) + [ToolInfo(CAMERA_TOOL, len(self.tools), np.zeros(5), np.append(self.scope.lower, 0.0),
                                            np.append(self.scope.upper, 0.0), pose, False)]

    def _move_camera(self, target, dt: float) -> None:
        """The laparoscope's pose this tick: towards the device's target at the scope's speeds, or
        the assistant's step towards the active tool; set in the model before the step."""
        if self.scope is None:
            return
        if self.camera_mode == "follow":
            active = self.device.active_tool if self.device is not None else None
            names = [tool.name for tool in self.tools]
            tool = active if active in names else names[0]
            self.camera_pose = self.scope.follow(self.physics, self.camera_pose, self.physics.working_point(tool), dt)
        elif target is not None:
            target = np.asarray(target, dtype=float)[:4]
            if target.shape == (4,) and np.all(np.isfinite(target)):  # a device's bad value never reaches MuJoCo
                reach = laparoscope.SPEED * dt
                step = np.clip(np.clip(target, self.scope.lower, self.scope.upper) - self.camera_pose, -reach, reach)
                self.camera_pose = self.camera_pose + step
        if self._applied is None or not np.array_equal(self._applied, self.camera_pose):  # a still scope costs nothing
            self.scope.apply(self.physics, self.camera_pose)
            self._applied = self.camera_pose.copy()

    # -- the tools, in user units (deg, m), COORDINATES order
    def _find_tools(self) -> None:
        model = self.model
        self.mapping = Tools(self.env)  # the tasks' mapping of tool coordinates to actuators
        self.tools: list[ToolInfo] = []
        self._qpos: dict[str, np.ndarray] = {}
        self._dof: dict[str, np.ndarray] = {}
        for index, name in enumerate(self.mapping.names):
            actuators = np.array(self.mapping.actuators[name])
            present = actuators >= 0
            lower, upper, kp = np.zeros(5), np.zeros(5), np.zeros(5)
            for k, a in enumerate(actuators):
                if a >= 0:
                    lower[k], upper[k] = model.actuator_ctrlrange[a] / TO_SI[k]
                    kp[k] = model.actuator_gainprm[a, 0]
            joints = [model.actuator_trnid[a, 0] if a >= 0 else -1 for a in actuators]
            self._qpos[name] = np.array([model.jnt_qposadr[j] if j >= 0 else -1 for j in joints])
            self._dof[name] = np.array([model.jnt_dofadr[j] if j >= 0 else -1 for j in joints])
            initial = np.where(present, self.data.ctrl[np.maximum(actuators, 0)] / TO_SI, 0.0)
            self.tools.append(ToolInfo(name, index, kp, lower, upper, initial, bool(present[4])))

    def _joint_values(self, name: str, source: np.ndarray, addresses: dict[str, np.ndarray]) -> np.ndarray:
        where = addresses[name]
        return np.where(where >= 0, source[np.maximum(where, 0)], 0.0) / TO_SI

    def snapshot(self, pinch: dict[str, float] | None = None) -> Snapshot:
        """The tools now (user units; forces in N, world frame); `pinch`, viscera.assess.pinches
        now, when the caller has it already."""
        sensors = self.physics.named.data.sensordata
        holding = {}
        for grasp in self.physics.intestine().grasps(self.data):
            holding[grasp.site.removesuffix("_tip")] = grasp.holding
        pinch = assess.pinches(self.physics) if pinch is None else pinch
        q, qdot, force, warning = {}, {}, {}, {}
        for tool in self.tools:
            q[tool.name] = self._joint_values(tool.name, self.data.qpos, self._qpos)
            qdot[tool.name] = self._joint_values(tool.name, self.data.qvel, self._dof)
            force[tool.name] = np.array(sensors[f"{tool.name}_force"][:3], dtype=float)
            warning[tool.name] = bool(np.linalg.norm(force[tool.name]) > assess.TRACTION_LIMIT_N
                                      or pinch.get(tool.name, 0.0) > assess.PERFORATION_PINCH_N
                                      or self.hold_force_time.get(tool.name, 0.0) > assess.FORCE_TIME_PRODUCT_LIMIT_NS)
        held = {t.name: holding.get(t.name, False) for t in self.tools}
        if self.camera_mode == "steer" and self.scope is not None:  # the scope as a device sees a tool
            q[CAMERA_TOOL], qdot[CAMERA_TOOL] = np.append(self.camera_pose, 0.0), np.zeros(5)
            force[CAMERA_TOOL], held[CAMERA_TOOL], warning[CAMERA_TOOL] = np.zeros(3), False, False
        return Snapshot(float(self.data.time), q, qdot, force, held, warning, pinch)

    def action(self) -> np.ndarray:
        """The dm_env action of the current commands (rad, m per actuator)."""
        return self.mapping.action(self.command)

    def tick(self) -> None:
        """One control tick: the device's targets, velocity-limited, stepped, recorded, fed back."""
        dt = self.control_timestep_s
        targets = self.device.targets(float(self.data.time)) if self.device else {}  # simulated time: rates integrate as the tools move
        for tool in self.tools:
            target = targets.get(tool.name)
            if target is None:
                continue
            target = np.asarray(target, dtype=float)
            if target.shape != (5,) or not np.all(np.isfinite(target)):
                continue  # a device's bad value never reaches MuJoCo
            command = self.command[tool.name]
            command += np.clip(np.clip(target, tool.lower, tool.upper) - command, -MAX_VELOCITY * dt, MAX_VELOCITY * dt)
        self._move_camera(targets.get(CAMERA_TOOL), dt)
        action = self.action()
        self.time_step = self.env.step(action)
        self.ticks += 1
        if self.recorder is not None:
            self.recorder.append(action, camera=self.camera_pose)
        pinches = self.tracer.sample(self.env)
        for tool, pinch in pinches.items():  # the current hold's force-time product
            self.hold_force_time[tool] = self.hold_force_time.get(tool, 0.0) + pinch * dt if pinch > 0.0 else 0.0
        if self.device is not None:
            self.device.feedback(self.snapshot(pinches))

    def ended(self) -> str | None:
        if not self.time_step.last():
            return None
        task = self.env.task
        if task.success(self.physics):
            return "success"
        return "failure" if task.failed else "time limit"

    def run(self, duration_s: float | None = None, progress: bool = False,
            on_frame: Callable[["Session"], bool] | None = None, lock=None) -> SessionResult:
        """Step in real time until the episode ends (or `duration_s` simulated seconds pass, or
        `on_frame`, called 30 times a wall second, returns False); then the result, with the
        recording and score. Each tick holds `lock` (a threading.Lock), if given, so that a
        display thread reads the data between ticks."""
        lock = lock if lock is not None else contextlib.nullcontext()
        dt = self.control_timestep_s
        bar = None
        if progress:
            from tqdm import tqdm
            bar = tqdm(total=round(self.time_limit_s / dt), unit="tick", desc=self.task_name)
        start = time.perf_counter()
        next_frame = start
        ended = None
        try:
            while ended is None:
                if duration_s is not None and self.data.time >= duration_s - 1e-9:
                    ended = "duration"
                    break
                with lock:
                    self.tick()
                if bar is not None:
                    bar.update(1)
                ended = self.ended()
                now = time.perf_counter()
                lag = now - (start + self.ticks * dt)
                if lag > 0.0:  # behind real time: count it, drop the lost time, never run faster
                    self.ticks_behind += 1
                    self.lost_s += lag
                    start += lag
                elif ended is None:
                    time.sleep(-lag)
                if on_frame is not None and time.perf_counter() >= next_frame:
                    next_frame = time.perf_counter() + FRAME_S
                    if not on_frame(self) and ended is None:
                        ended = "window closed"
        except KeyboardInterrupt:
            ended = "interrupted"
        finally:
            if bar is not None:
                bar.close()
        return self.result(ended)

    def result(self, ended: str) -> SessionResult:
        recording = self.recorder.finish(self.env) if self.recorder is not None else None
        score = assess.score(self.tracer.trace)
        return SessionResult(ended, ended == "success", float(self.data.time), self.ticks, self.ticks_behind,
                             self.lost_s, recording, score)

    def close(self) -> None:
        if self.device is not None:
            self.device.close()
