"""Scripted trocar tool trajectories: waypoints in tool coordinates against time.

A laparoscopic tool pivots at its trocar: its coordinates are the two pivot
angles (pitch, yaw, degrees), the insertion depth below the trocar (m), the
roll about the shaft (degrees) and the jaw opening (degrees). A trajectory is a
list of waypoints; between two waypoints every coordinate follows the quintic
smoothstep 10u^3 - 15u^4 + 6u^5 (zero velocity and acceleration at each
waypoint). Its peak speed is 1.875 |change| / duration, so a segment too short
for a coordinate's velocity limit is stretched, and the later waypoints move
later: limits always hold.

    trajectory = ToolTrajectory.from_file("gesture.json")   # or ToolTrajectory([...])
    player = ToolPlayer(model, "grasper", trajectory)
    player.apply(data)                                       # before each mj_step: writes data.ctrl

The file is JSON: {"waypoints": [{"time": 0, "pitch": 0, ...}, ...],
"max_velocity": {"depth": 0.05, ...}} (coordinates left out keep their
previous value, 0 at the start).
"""

from __future__ import annotations

import dataclasses
import json
from typing import Mapping, Sequence

import mujoco
import numpy as np

COORDINATES = ("pitch", "yaw", "depth", "roll", "jaw")
UNITS = {"pitch": "deg", "yaw": "deg", "depth": "m", "roll": "deg", "jaw": "deg"}
# each coordinate's unit to SI (deg -> rad; m stays m), in COORDINATES' order
TO_SI = tuple(np.pi / 180.0 if UNITS[c] == "deg" else 1.0 for c in COORDINATES)
DEFAULT_MAX_VELOCITY = {"pitch": 30.0, "yaw": 30.0, "depth": 0.05, "roll": 90.0, "jaw": 60.0}  # per second
PEAK_SPEED = 1.875  # of the quintic smoothstep, times change / duration


@dataclasses.dataclass(frozen=True)
class Waypoint:
    time: float                 # s
    values: np.ndarray          # pitch (deg), yaw (deg), depth (m), roll (deg), jaw (deg)


class ToolTrajectory:
    """Smooth, velocity-limited interpolation of tool waypoints (see the module doc)."""

    def __init__(self, waypoints: Sequence[Mapping[str, float]],
                 max_velocity: Mapping[str, float] | None = None):
        if not waypoints:
            raise ValueError("a trajectory needs at least one waypoint")
        limits = dict(DEFAULT_MAX_VELOCITY)
        for key, value in (max_velocity or {}).items():
            if key not in COORDINATES or not (np.isfinite(value) and value > 0):
                raise ValueError(f"max_velocity '{key}' = {value!r}: must be one of {COORDINATES} and positive")
            limits[key] = float(value)
        self.max_velocity = np.array([limits[c] for c in COORDINATES])
        values = np.zeros(len(COORDINATES))
        times = []
        self.waypoints: list[Waypoint] = []
        for index, point in enumerate(waypoints):
            unknown = set(point) - set(COORDINATES) - {"time"}
            if unknown:
                raise ValueError(f"waypoint {index}: unknown keys {sorted(unknown)}; known: time, {COORDINATES}")
            if "time" not in point or not np.isfinite(point["time"]):
                raise ValueError(f"waypoint {index}: 'time' must be a finite number of seconds")
            values = values.copy()
            for k, name in enumerate(COORDINATES):
                if name in point:
                    if not np.isfinite(point[name]):
                        raise ValueError(f"waypoint {index}: '{name}' = {point[name]!r} is not finite")
                    values[k] = float(point[name])
            if times and point["time"] < times[-1]:
                raise ValueError(f"waypoint {index}: time {point['time']} goes backwards")
            times.append(float(point["time"]))
            self.waypoints.append(Waypoint(float(point["time"]), values))
        self._retime()

    def _retime(self) -> None:
        """Stretch segments whose quintic would exceed a velocity limit."""
        shift = 0.0
        retimed = [dataclasses.replace(self.waypoints[0])]
        for previous, current in zip(self.waypoints, self.waypoints[1:]):
            needed = float(np.max(PEAK_SPEED * np.abs(current.values - previous.values) / self.max_velocity))
            duration = max(current.time - previous.time, needed)
            shift += duration - (current.time - previous.time)
            retimed.append(Waypoint(retimed[-1].time + duration, current.values))
        self.waypoints = retimed
        self.delay = shift  # s added by the velocity limits

    @classmethod
    def from_file(cls, path: str) -> "ToolTrajectory":
        with open(path) as f:
            spec = json.load(f)
        return cls(spec["waypoints"], spec.get("max_velocity"))

    @property
    def duration(self) -> float:
        return self.waypoints[-1].time

    def __call__(self, t: float) -> np.ndarray:
        """Coordinates at time t (s): pitch, yaw (deg), depth (m), roll, jaw (deg)."""
        points = self.waypoints
        if t <= points[0].time:
            return points[0].values.copy()
        for a, b in zip(points, points[1:]):
            if t <= b.time:
                span = b.time - a.time
                u = 1.0 if span <= 0 else (t - a.time) / span
                s = u * u * u * (10.0 + u * (-15.0 + 6.0 * u))
                return a.values + s * (b.values - a.values)
        return points[-1].values.copy()


class ToolPlayer:
    """Plays a trajectory through a tool's position actuators (named <tool>_pitch, ...)."""

    def __init__(self, model: mujoco.MjModel, tool: str, trajectory: ToolTrajectory, start: float = 0.0):
        self.trajectory = trajectory
        self.start = start
        self.actuators = []
        for name in COORDINATES:
            actuator = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, f"{tool}_{name}")
            self.actuators.append(actuator)
        missing = [name for name, a in zip(COORDINATES, self.actuators) if a < 0 and name != "jaw"]
        if missing:  # every tool pivots, inserts and rolls; only graspers have a jaw
            raise KeyError(f"the model has no actuators {[f'{tool}_{m}' for m in missing]}")
        # MJCF angles are in degrees (compiler angle="degree"); MuJoCo stores radians
        self.scale = np.array([np.pi / 180, np.pi / 180, 1.0, np.pi / 180, np.pi / 180])

    def apply(self, data: mujoco.MjData) -> np.ndarray:
        """Write the trajectory's targets at data.time into data.ctrl; returns them (tool units)."""
        values = self.trajectory(data.time - self.start)
        for actuator, value, scale in zip(self.actuators, values, self.scale):
            if actuator >= 0:
                data.ctrl[actuator] = value * scale
        return values
