"""Scripted closed-loop policies for the tasks (dm_control convention: `action = policy(time_step)`),
built from the observations alone, plus the scene's fixed geometry (trocars, tool lengths).

Each policy queues phases: smooth, velocity-limited tool moves (viscera.trajectory) of set
durations; when the queue runs dry it plans again from the latest observations. `Tools` turns a
point in the cavity into the tool coordinates (pitch, yaw, depth, roll, jaw) that put the tool's
working point there, and a set of tool commands into the action vector.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from viscera.numerics import norm
from viscera.trajectory import COORDINATES, ToolTrajectory

JAW_OPEN_DEG = 35.0
JAW_CLOSED_DEG = 0.0
LIMITS = {"pitch": 60.0, "yaw": 60.0, "depth": 0.15, "roll": 90.0, "jaw": 200.0}  # per second


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


@dataclasses.dataclass
class Phase:
    name: str
    duration: float                           # s, at least
    moves: dict[str, ToolTrajectory]          # per tool; tools left out hold


class PhasedPolicy:
    """Plays queued phases; `plan(observation)` queues more when they run out."""

    def __init__(self, env):
        self.tools = Tools(env)
        self.control_timestep = env.control_timestep()
        self.reset()

    def reset(self) -> None:
        self.phases: list[Phase] = []
        self.phase_time = 0.0
        self.time = 0.0
        self.command = {t: {c: 0.0 for c in COORDINATES} for t in self.tools.names}

    def move(self, tool: str, goal: dict, duration: float) -> ToolTrajectory:
        """A move of `tool` from where it was last sent to `goal` (tool coordinates)."""
        start = dict(self.command[tool])
        self.command[tool] = dict(goal)
        return ToolTrajectory([dict(start, time=0.0), dict(goal, time=duration)], LIMITS)

    def to(self, tool: str, point, jaw: float, duration: float) -> ToolTrajectory:
        """A move of `tool`'s working point to `point` (m) with the jaw at `jaw` (deg)."""
        return self.move(tool, self.tools.coordinates(tool, point, jaw), duration)

    def up_the_shaft(self, tool: str, point, height: float) -> dict:
        """The tool's coordinates drawn back along its shaft from `point` (m) until the working
        point is `height` m up: the shaft keeps its angles, which may be at their limits."""
        d = np.asarray(point, dtype=float) - self.tools.trocar[tool]
        rise = (height - float(point[2])) * norm(d) / max(1e-6, -d[2])
        return dict(self.command[tool], depth=max(0.0, self.command[tool]["depth"] - rise))

    def jaw(self, tool: str, jaw: float, duration: float) -> ToolTrajectory:
        return self.move(tool, dict(self.command[tool], jaw=jaw), duration)

    def withdraw(self, tool: str, duration: float = 1.2) -> ToolTrajectory:
        return self.move(tool, dict(self.command[tool], depth=0.0), duration)

    def plan(self, observation) -> None:
        raise NotImplementedError

    @property
    def phase(self) -> str:
        return self.phases[0].name if self.phases else "-"

    def __call__(self, time_step) -> np.ndarray:
        if time_step.first():
            self.reset()
            self.command = self.tools.commands(time_step.observation)  # from where the tools start
        while not self.phases or self.phase_time >= self.phases[0].duration:
            if self.phases:
                self.phase_time -= self.phases.pop(0).duration
            if not self.phases:
                self.plan(time_step.observation)
                if not self.phases:  # nothing to do: hold still, look again next step
                    self.phases.append(Phase("rest", self.control_timestep, {}))
            # a move the velocity limits stretched finishes before the next phase starts from its goal
            self.phases[0].duration = max([self.phases[0].duration] + [move.duration for move in self.phases[0].moves.values()])
        phase = self.phases[0]
        values = {}
        for tool in self.tools.names:
            move = phase.moves.get(tool)
            values[tool] = move(self.phase_time) if move is not None else np.array(
                [self.command[tool][c] for c in COORDINATES])
        self.phase_time += self.control_timestep
        self.time += self.control_timestep
        return self.tools.action(values)


def axis_point(observation, abscissa: float, length: float) -> np.ndarray:
    """The observed axis point nearest `abscissa` (m along the rest axis of `length` m)."""
    axis = np.asarray(observation["intestine_axis"]).reshape(-1, 3)
    return axis[int(round(np.clip(abscissa / length, 0.0, 1.0) * (len(axis) - 1)))]


class GraspLiftPolicy(PhasedPolicy):
    """grasp_lift: over the band's highest point, down, close, lift to 9 cm and hold; if the jaws
    take anything but the band, or nothing, open, rise and try the next band point."""

    lift_height = 0.09  # m

    def reset(self) -> None:
        super().reset()
        self.attempt = 0

    def plan(self, observation) -> None:
        g = "grasper"
        band = np.asarray(observation["band"]).reshape(-1, 3)
        low, high = observation["band_abscissa"]
        held = float(observation["held_abscissa"][0])
        if held >= 0.0 and low - 0.01 <= held <= high + 0.01:  # holding the band: keep it up
            return
        if held >= 0.0 or self.attempt:  # the wrong loop, or a miss: let go and rise
            top = dict(self.command[g], jaw=JAW_OPEN_DEG)
            self.phases.append(Phase("let go", 0.3, {g: self.move(g, top, 0.25)}))
            self.phases.append(Phase("rise", 0.4, {g: self.move(g, dict(top, depth=max(0.0, top["depth"] - 0.04)),
                                                                 0.35)}))
        order = np.argsort(-band[:, 2])  # the highest band points first
        pick = band[order[self.attempt % len(band)]]
        radius = 0.0125
        self.phases += [
            Phase("approach", 0.9, {g: self.to(g, pick + (0, 0, 0.04), JAW_OPEN_DEG, 0.8)}),
            Phase("descend", 0.5, {g: self.to(g, pick - (0, 0, 0.3 * radius), JAW_OPEN_DEG, 0.4)}),
            Phase("close", 0.3, {g: self.jaw(g, JAW_CLOSED_DEG, 0.25)}),
            Phase("lift", 0.8, {g: self.move(g, self.up_the_shaft(g, pick, self.lift_height), 0.7)}),
        ]
        self.attempt += 1


class RunTheBowelPolicy(PhasedPolicy):
    """run_the_bowel: hand over hand. The first grasper takes the start mark and lifts it; then,
    in turn, the free grasper takes the bowel `stride` further along and lifts it, and only once
    it holds does the other let go and rise (a miss is tried again); the run goes the way with
    more bowel ahead."""

    stride = 0.06        # m of bowel per hand-over
    lift = 0.015         # m a hold is raised: off the pile, not enough to tear it from under other loops
    first_slack = 0.03   # m: the task counts a first hold this close to the mark ...
    handover = 0.10      # ... and a later one this close, along the bowel, to the other jaw's hold

    def reset(self) -> None:
        super().reset()
        self.next_abscissa = None
        self.direction = 1.0
        self.turn = 0
        self.grabbing = False
        self.mark = None

    def counts(self, held: np.ndarray, index: int) -> bool:
        """Whether jaw `index`'s new hold counts as the task counts it, and moves the run on."""
        if self.turn == 0:
            return abs(held[index] - self.mark) <= self.first_slack
        others = [s for j, s in enumerate(held) if j != index and s >= 0.0]
        return any(abs(held[index] - s) <= self.handover and (held[index] - s) * self.direction > 0.0 for s in others)

    def plan(self, observation) -> None:
        graspers = [t for t in self.tools.names if t.startswith("grasper")]
        held = np.asarray(observation["held_abscissa"])
        length = float(observation["intestine_length"][0])
        if self.next_abscissa is None:
            self.mark = float(observation["start_mark"][3])
            self.direction = 1.0 if self.mark < 0.5 * length else -1.0
            self.next_abscissa = self.mark
        index = self.turn % len(graspers)
        hand, other = graspers[index], graspers[(index + 1) % len(graspers)]
        if self.grabbing and held[index] >= 0.0 and not self.counts(held, index):
            held = held.copy()  # took another loop than the one aimed at: let go and try again below
            held[index] = -1.0
        if self.grabbing and held[index] >= 0.0:  # the hand holds: the other lets go and rises
            self.grabbing = False
            if held[(index + 1) % len(graspers)] >= 0.0:
                top = dict(self.command[other], jaw=JAW_OPEN_DEG)
                self.phases += [
                    Phase(f"{other} let go", 0.3, {other: self.move(other, top, 0.25)}),
                    Phase(f"{other} rise", 0.4, {other: self.move(other, dict(top, depth=max(0.0, top["depth"] - 0.05)),
                                                                  0.35)})]
            self.next_abscissa = float(held[index]) + self.direction * self.stride
            self.turn += 1
            return
        if self.grabbing:  # missed: open and rise before trying again
            top = dict(self.command[hand], jaw=JAW_OPEN_DEG)
            self.phases.append(Phase(f"{hand} open", 0.3, {hand: self.move(hand, top, 0.25)}))
        point = axis_point(observation, self.next_abscissa, length)
        self.phases += [
            Phase(f"{hand} approach", 0.8, {hand: self.to(hand, point + (0, 0, 0.04), JAW_OPEN_DEG, 0.7)}),
            Phase(f"{hand} descend", 0.5, {hand: self.to(hand, point - (0, 0, 0.004), JAW_OPEN_DEG, 0.4)}),
            Phase(f"{hand} close", 0.3, {hand: self.jaw(hand, JAW_CLOSED_DEG, 0.25)}),
            Phase(f"{hand} lift", 0.5, {hand: self.to(hand, point + (0, 0, self.lift), JAW_CLOSED_DEG, 0.45)}),
        ]
        self.grabbing = True
