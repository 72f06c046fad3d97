"""Scripted oracles: policies that decide every control step from the observation they are handed.

    oracle = viscera.tasks.scripted_policy(env)        # the task's oracle (an Oracle)
    decision = oracle.decide(time_step.observation)    # the action, and what the oracle is doing
    decision.action                                    # the dm_env action (rad, m)
    decision.phase, decision.lead, decision.aims       # e.g. "descend", "grasper", {"grasper": xyz}
    action = oracle(time_step)                         # dm_control's convention: decide(...).action

An oracle keeps no memory of the episode: its phase, the tool that leads and each tool's aim
(where its working point is going, m, world) are functions of the observation alone, the
tools' last commands (`tool_command`) included, plus the scene's fixed geometry read when it is
built (trocars, tool lengths, the mesentery's root). So a fresh oracle handed any state of an
episode acts exactly as one that played the episode from its start would, and an oracle labels
a learner's own states (DAgger) rather than replaying a timeline. A choice that must hold
through a cycle (which loop to carry where, which hand grasps next) is made by a rule the state
reproduces: a score whose best choice stays best as the tool moves towards it, or a test on
what is observed (a hold, the jaw, the tip's place).

The tools move as a person's hand does towards a goal: each step, a tool's working point goes
a share of the way left along the straight line from where it was last sent to where it is
going, at most TIP_SPEED and slowing within SETTLE_S of the goal; the command is the last
command plus that step, so it depends on the state only. Roll and jaw turn at their own limits.

`Decision.vector()` packs a decision into fixed-size numbers for datasets (the phase's index in
the oracle's PHASES, the lead tool's index, each tool's aim; a tool held still aims where it is
held).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from viscera.numerics import norm
from viscera.trajectory import COORDINATES

JAW_OPEN_DEG = 35.0
JAW_CLOSED_DEG = 0.0
LIMITS = {"pitch": 60.0, "yaw": 60.0, "depth": 0.15, "roll": 90.0, "jaw": 200.0}  # per second (deg, m)
TIP_SPEED = 0.12  # m/s, a working point's top speed (about the velocity limits at the tools' reach)
SETTLE_S = 0.12  # s: a move's last stretch is an exponential approach with this time constant
ARRIVED_M = 0.004  # m: a working point this close to its aim has arrived


class Tools:
    """The tools of an environment's scene: their trocars, working points and actuators."""

    def __init__(self, env):
        physics = env.physics
        model = physics.model
        self.names = physics.tools()
        self.trocar = {t: physics.named.model.body_pos[f"{t}_trocar"].copy() for t in self.names}
        # distance from the trocar to the working point at zero depth (m): a grasper's tip site,
        # a retractor's paddle
        self.tip_offset = {}
        for t in self.names:
            if f"{t}_tip" in physics.named.model.site_pos.axes.row.names:
                self.tip_offset[t] = -float(physics.named.model.site_pos[f"{t}_tip"][2])
            else:
                self.tip_offset[t] = -float(physics.named.model.geom_pos[f"{t}_paddle"][2])
        names = physics.named.data.ctrl.axes.row.names
        self.actuators = {t: [model.actuator(f"{t}_{c}").id if f"{t}_{c}" in names else -1 for c in COORDINATES]
                          for t in self.names}
        self.action_size = model.nu
        # where each tool coordinate is in the observation tool_joints (rad, m), in its order
        joints = list(physics.tool_index().joint_names)
        self.joint_entry = {t: {c: joints.index(f"{t}_{c}") for c in COORDINATES if f"{t}_{c}" in joints}
                            for t in self.names}

    def commands(self, observation) -> dict[str, dict[str, float]]:
        """Each tool's coordinates (deg, m) as the observation `tool_joints` has them: where the
        tools are, the start of a policy's first moves (the tasks start with the tools in view)."""
        joints = np.asarray(observation["tool_joints"], dtype=float)
        return {t: {c: (float(joints[entries[c]]) if c == "depth" else math.degrees(float(joints[entries[c]])))
                    if c in entries else 0.0 for c in COORDINATES}
                for t, entries in self.joint_entry.items()}

    def coordinates(self, tool: str, point, jaw: float = 0.0, roll: float = 0.0) -> dict:
        """Tool coordinates (deg, m) that put the tool's working point at `point` (m, world): the
        shaft pivots at the trocar (pitch about x, then yaw about y). Bit for bit the same on any
        CPU (viscera.numerics)."""
        d = np.asarray(point, dtype=float) - self.trocar[tool]
        distance = norm(d)
        u = d / distance
        yaw = math.degrees(math.asin(min(1.0, max(-1.0, -float(u[0])))))
        pitch = math.degrees(math.atan2(float(u[1]), -float(u[2])))
        depth = float(np.clip(distance - self.tip_offset[tool], 0.0, 0.22))
        return {"pitch": pitch, "yaw": yaw, "depth": depth, "roll": roll, "jaw": jaw}

    def action(self, values: dict[str, np.ndarray]) -> np.ndarray:
        """The action vector from each tool's coordinates (deg, m; COORDINATES order)."""
        action = np.zeros(self.action_size)
        for tool, coordinates in values.items():
            for actuator, value, name in zip(self.actuators[tool], coordinates, COORDINATES):
                if actuator >= 0:
                    action[actuator] = value if name == "depth" else math.radians(float(value))
        return action


@dataclasses.dataclass(frozen=True)
class Decision:
    """One control step's decision: the action and what the oracle is doing."""
    action: np.ndarray                 # the dm_env action (rad, m), actuator order
    phase: str                         # one of the oracle's PHASES
    lead: str                          # the tool the phase is about
    aims: dict                         # tool -> where its working point is going (m, world, (3,)); every tool

    def vector(self, phases: tuple[str, ...], tools: tuple[str, ...]) -> np.ndarray:
        """[phase index, lead tool index, then each tool's aim (m) in `tools` order]."""
        return np.concatenate([[float(phases.index(self.phase)), float(tools.index(self.lead))]]
                              + [np.asarray(self.aims[t], dtype=float) for t in tools])


def shaft_direction(pitch_deg: float, yaw_deg: float) -> np.ndarray:
    """The unit vector from a trocar along the shaft at `pitch_deg` (about x) and `yaw_deg` (about y),
    the inverse of Tools.coordinates' angles."""
    pitch, yaw = math.radians(pitch_deg), math.radians(yaw_deg)
    return np.array([-math.sin(yaw), math.cos(yaw) * math.sin(pitch), -math.cos(yaw) * math.cos(pitch)])


class Oracle:
    """A task's oracle (see the module doc); a task's subclass defines PHASES and `decide`."""

    PHASES: tuple[str, ...] = ()

    def __init__(self, env):
        self.tools = Tools(env)
        self.names = tuple(self.tools.names)
        self.control_timestep = env.control_timestep()
        self.last: Decision | None = None
        # each tool coordinate's range (deg, m): the actuators' control ranges
        ranges = env.physics.model.actuator_ctrlrange
        self.ranges = {t: {c: ((float(ranges[a][0]), float(ranges[a][1])) if c == "depth" else
                               (math.degrees(float(ranges[a][0])), math.degrees(float(ranges[a][1]))))
                           if a >= 0 else (0.0, 0.0) for c, a in zip(COORDINATES, self.tools.actuators[t])}
                       for t in self.names}

    # -- reading the observation
    def commands(self, observation) -> dict[str, dict[str, float]]:
        """Each tool's last command (deg, m) from the observation `tool_command` (actuator order)."""
        command = np.asarray(observation["tool_command"], dtype=float)
        return {t: {c: (float(command[a]) if c == "depth" else math.degrees(float(command[a]))) if a >= 0 else 0.0
                    for c, a in zip(COORDINATES, self.tools.actuators[t])} for t in self.names}

    def joints(self, observation) -> dict[str, dict[str, float]]:
        """Each tool's coordinates as they are (deg, m), from `tool_joints`."""
        return self.tools.commands(observation)

    def tip(self, tool: str, coordinates: dict) -> np.ndarray:
        """The working point (m, world) of `tool` at `coordinates` (deg, m)."""
        reach = coordinates["depth"] + self.tools.tip_offset[tool]
        return self.tools.trocar[tool] + reach * shaft_direction(coordinates["pitch"], coordinates["yaw"])

    # -- goals
    def at(self, tool: str, point, jaw: float, roll: float = 0.0) -> dict:
        """Tool coordinates (deg, m) that put `tool`'s working point at `point` (m), or as near as
        the actuators' ranges let it."""
        return self.within_range(tool, self.tools.coordinates(tool, point, jaw, roll))

    def within_range(self, tool: str, coordinates: dict) -> dict:
        """`coordinates` (deg, m) clipped to `tool`'s ranges (the jaw and a missing coordinate kept)."""
        ranges = self.ranges[tool]
        return {c: min(ranges[c][1], max(ranges[c][0], v)) if c != "jaw" and ranges[c][0] < ranges[c][1] else v
                for c, v in coordinates.items()}

    def at_height(self, tool: str, command: dict, height: float) -> dict:
        """`command` drawn along its shaft (angles kept) until the working point is at `height` (m, z)."""
        u = shaft_direction(command["pitch"], command["yaw"])
        reach = (height - float(self.tools.trocar[tool][2])) / min(-1e-6, float(u[2]))
        return self.within_range(tool, dict(command, depth=reach - self.tools.tip_offset[tool]))

    # -- acting
    def step_towards(self, tool: str, command: dict, goal: dict) -> dict:
        """The next command of `tool` from `command` towards `goal` (both deg, m): its working
        point a share of the way along the straight line between theirs, at most TIP_SPEED and
        slowing within SETTLE_S of the goal; the roll and the jaw at their own limits."""
        dt = self.control_timestep
        start, end = self.tip(tool, command), self.tip(tool, goal)
        distance = norm(end - start)
        share = min(1.0, dt / max(distance / TIP_SPEED, SETTLE_S))
        if distance <= 1e-9 or norm(start - self.tools.trocar[tool]) <= 1e-6:
            out = dict(command, pitch=goal["pitch"], yaw=goal["yaw"], depth=goal["depth"])
        else:
            out = self.within_range(tool, self.tools.coordinates(tool, start + share * (end - start)))
        for c in ("roll", "jaw"):
            limit = LIMITS[c] * dt
            out[c] = command[c] + min(limit, max(-limit, goal[c] - command[c]))
        return out

    def act(self, observation, goals: dict, phase: str, lead: str, aims: dict) -> Decision:
        """The decision that moves each tool from its last command towards its goal (tools left
        out of `goals` hold their command)."""
        commands = self.commands(observation)
        values = {}
        for tool in self.names:
            nxt = self.step_towards(tool, commands[tool], goals[tool]) if tool in goals else commands[tool]
            values[tool] = np.array([nxt[c] for c in COORDINATES])
        assert phase in self.PHASES, phase
        # a tool without an aim is held where it was last sent: that is its aim
        aims = {t: np.asarray(aims[t], dtype=float) if t in aims else self.tip(t, commands[t]) for t in self.names}
        return Decision(self.tools.action(values), phase, lead, aims)

    def decide(self, observation) -> Decision:
        raise NotImplementedError

    def __call__(self, time_step) -> np.ndarray:
        self.last = self.decide(time_step.observation)
        return self.last.action

    @property
    def phase(self) -> str:
        """The phase of the last decision ("-" before the first)."""
        return self.last.phase if self.last is not None else "-"
