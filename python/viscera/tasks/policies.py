"""The scripted oracles of grasp_lift and run_the_bowel (viscera.tasks.oracle: each control step,
the phase, the aims and the action from the observation alone), plus `Tools`, a scene's tools
(viscera.tasks.oracle.Tools), for the gestures built on them.

A grasp goes the same way in both: the open jaws over the point to take (`approach`, first
straight up the shaft when the tip is low and far from it: `rise`), down to just under the
point's axis (`descend`), shut (`close`); a jaw shut on nothing opens where it is (`open`), a hold
the task does not count lets go (`let go`), a hold that counts is raised (`lift`) and kept
(`hold`). Which point to take is chosen by a score that stays best while the tip goes to it (its
height, less the tip's horizontal distance to it): the choice holds through the approach without
being remembered.
"""

from __future__ import annotations

import math

import numpy as np

from viscera.numerics import norm
from viscera.tasks.base import shaft_within_reach
from viscera.tasks.oracle import JAW_CLOSED_DEG, JAW_OPEN_DEG, LIMITS, Decision, Oracle, Tools  # noqa: F401

CLEARANCE_M = 0.04      # the open jaws come this far above the point they go for
NEAR_M = 0.01           # the tip this close to the point horizontally is over it
LOW_M = 0.02            # a tip lower than this above the point, and farther than FAR_M, rises first
FAR_M = 0.025
JAW_SHUT_DEG = 1.0      # a jaw at or under this has shut (on nothing, if it holds nothing)
SENT_M = 0.005          # a command whose working point is this close to the goal's has been sent there
TAUT = 0.85            # bowel whose chord is this share of its length along the axis runs taut
COMMAND_AT_DEG = 0.3    # a command this close to its goal's angles ...
COMMAND_AT_M = 0.0015   # ... and depth has arrived


class GraspPolicy(Oracle):
    """What the grasping oracles share: the phases of one grasp, from the state."""

    PHASES = ("approach", "rise", "descend", "close", "open", "let go", "lift", "hold")
    grip_below = 0.004  # m under the point's axis the jaws close

    def __init__(self, env):
        super().__init__(env)
        gut = env.physics.intestine()
        self.radius = gut.radius
        self.rest_length = gut.rest_length

    def arrived(self, command: dict, goal: dict) -> bool:
        """The command has reached `goal` (deg, m): the tool is being held there."""
        return (abs(command["pitch"] - goal["pitch"]) <= COMMAND_AT_DEG
                and abs(command["yaw"] - goal["yaw"]) <= COMMAND_AT_DEG
                and abs(command["depth"] - goal["depth"]) <= COMMAND_AT_M)

    def grasp(self, observation, tool: str, point) -> tuple[str, dict, np.ndarray]:
        """The phase, the goal (deg, m) and the aim (m) of `tool`, free, going for `point` (m)."""
        command, now = self.commands(observation)[tool], self.joints(observation)[tool]
        tip = self.tip(tool, now)
        point = np.asarray(point, dtype=float)
        grip = point - np.array([0.0, 0.0, self.grip_below])
        # over the point at its clearance, or at the tip's height if higher: no dip on the way
        above = np.array([point[0], point[1], max(point[2] + CLEARANCE_M, tip[2])])
        across = norm((tip - point)[:2])
        if command["jaw"] < JAW_OPEN_DEG - 0.5:  # the jaws are not (yet) open, holding nothing
            # opening (the command leads the jaw up), or shut on nothing: open where they are
            if command["jaw"] > now["jaw"] + JAW_SHUT_DEG or now["jaw"] <= JAW_SHUT_DEG:
                return "open", dict(command, jaw=JAW_OPEN_DEG), tip
            return "close", dict(command, jaw=JAW_CLOSED_DEG), tip  # where they are: no chasing
        approach = self.at(tool, above, JAW_OPEN_DEG)
        # over the point, or as near it as the tool reaches; going down, within a wider circle
        near = NEAR_M + norm((self.tip(tool, approach) - above)[:2])
        if across > near and not (across <= near + NEAR_M and tip[2] < above[2] - NEAR_M):
            if across > FAR_M and (tip[2] < point[2] + LOW_M or self.near_bowel(observation, tip)):
                # up first, straight along the shaft: a tip low among the loops drags them along
                return "rise", self.at_height(tool, dict(command, jaw=JAW_OPEN_DEG), tip[2] + CLEARANCE_M), \
                    np.array([tip[0], tip[1], tip[2] + CLEARANCE_M])
            return "approach", approach, above
        goal = self.at(tool, grip, JAW_OPEN_DEG)
        # the jaws close once sent there (a bowel pushed ahead of them is followed: the command
        # is then at most SENT_M behind the moving goal), wherever the bowel stopped them
        if norm(self.tip(tool, command) - self.tip(tool, goal)) > SENT_M:
            return "descend", goal, grip
        return "close", self.at(tool, grip, JAW_CLOSED_DEG), grip

    def near_bowel(self, observation, tip: np.ndarray) -> bool:
        """Some of the bowel lies just under the tip (within FAR_M across, its axis at most LOW_M below)."""
        axis = np.asarray(observation["intestine_axis"], dtype=float).reshape(-1, 3)
        across = ((axis[:, :2] - tip[:2]) ** 2).sum(axis=1)
        below = tip[2] - axis[:, 2]
        return bool(np.any((across < FAR_M ** 2) & (below > -self.radius) & (below < LOW_M)))

    def keep(self, observation, tool: str, height: float) -> tuple[str, dict, np.ndarray]:
        """`tool`, holding, raised along its shaft to `height` (m) and kept there, jaws shut."""
        command, now = self.commands(observation)[tool], self.joints(observation)[tool]
        if now["jaw"] > JAW_SHUT_DEG:  # still closing: the pinch builds before the pull
            return "close", dict(command, jaw=JAW_CLOSED_DEG), self.tip(tool, now)
        goal = self.at_height(tool, dict(command, jaw=JAW_CLOSED_DEG), height)
        aim = self.tip(tool, goal)
        return ("hold" if self.arrived(command, goal) else "lift"), goal, aim

    def let_go(self, observation, tool: str) -> tuple[str, dict, np.ndarray]:
        command = self.commands(observation)[tool]
        return "let go", dict(command, jaw=JAW_OPEN_DEG), self.tip(tool, self.joints(observation)[tool])

    def exposed(self, axis: np.ndarray, point: np.ndarray, abscissa: float) -> bool:
        """No other stretch of the bowel (farther than 5 cm along it) lies on `point` (m)."""
        along = np.abs(np.linspace(0.0, self.rest_length, len(axis)) - abscissa)
        near = ((axis[:, :2] - point[:2]) ** 2).sum(axis=1) < (1.5 * self.radius) ** 2
        return not np.any((along > 0.05) & near & (axis[:, 2] > point[2] + self.radius))

    def choose(self, tip: np.ndarray, points: np.ndarray, exposed: np.ndarray) -> int:
        """The point to go for: the highest exposed one, less the tip's horizontal distance to it
        (so the choice stays while the tip goes to it)."""
        across = np.sqrt(((points[:, :2] - tip[:2]) ** 2).sum(axis=1))
        score = points[:, 2] - 0.5 * across - np.where(exposed, 0.0, 1.0)
        return int(np.argmax(score))


class GraspLiftPolicy(GraspPolicy):
    """grasp_lift: the grasper takes the band's highest exposed point and lifts it to 9 cm; a hold
    of anything but the band lets go."""

    lift_height = 0.09  # m

    def decide(self, observation) -> Decision:
        g = "grasper"
        band = np.asarray(observation["band"], dtype=float).reshape(-1, 3)
        low, high = (float(v) for v in observation["band_abscissa"])
        held = float(observation["held_abscissa"][0])
        if held >= 0.0 and low - 0.01 <= held <= high + 0.01:
            phase, goal, aim = self.keep(observation, g, self.lift_height)
        elif held >= 0.0:
            phase, goal, aim = self.let_go(observation, g)
        else:
            axis = np.asarray(observation["intestine_axis"], dtype=float).reshape(-1, 3)
            abscissae = np.linspace(low, high, len(band))
            exposed = np.array([self.exposed(axis, p, s) for p, s in zip(band, abscissae)])
            tip = self.tip(g, self.joints(observation)[g])
            pick = band[self.choose(tip, band, exposed)]
            phase, goal, aim = self.grasp(observation, g, pick)
        return self.act(observation, {g: goal}, phase, g, {g: aim})


class RunTheBowelPolicy(GraspPolicy):
    """run_the_bowel: hand over hand. Before the run, the first grasper takes the start mark. Then
    the free grasper takes the bowel `stride` beyond the leading counted hold (the way with more
    bowel ahead); once both holds count, the trailing one lets go; a hold the task does not
    count (`counted_abscissa` -1: another loop) lets go. A holding grasper lifts its hold `lift`
    above the bowel on either side of it."""

    stride = 0.06        # m of bowel per hand-over ...
    strides = (0.06, 0.05, 0.07, 0.04, 0.08, 0.03)  # ... or the nearest of these the free hand reaches
    lift = 0.015         # m: off the pile, not enough to tear it from under other loops

    def axis_point(self, axis: np.ndarray, abscissa: float) -> np.ndarray:
        """The observed axis point nearest `abscissa` (m along the rest axis)."""
        return axis[int(round(min(1.0, max(0.0, abscissa / self.rest_length)) * (len(axis) - 1)))]

    def decide(self, observation) -> Decision:
        hands = [t for t in self.names if t.startswith("grasper")]
        held = np.asarray(observation["held_abscissa"], dtype=float)
        counted = np.asarray(observation["counted_abscissa"], dtype=float)
        mark = float(observation["start_mark"][3])
        direction = 1.0 if mark < 0.5 * float(observation["intestine_length"][0]) else -1.0
        axis = np.asarray(observation["intestine_axis"], dtype=float).reshape(-1, 3)
        good = [i for i in range(len(hands)) if held[i] >= 0.0 and counted[i] >= 0.0]
        phases, goals, aims = {}, {}, {}
        trailing = min(good, key=lambda i: direction * held[i]) if len(good) == 2 else None
        for i, hand in enumerate(hands):
            if held[i] >= 0.0 and (counted[i] < 0.0 or i == trailing):
                phases[hand], goals[hand], aims[hand] = self.let_go(observation, hand)
            elif held[i] >= 0.0:
                s = float(held[i])
                sides = [self.axis_point(axis, s + d)[2] for d in (-0.08, 0.08)]
                phases[hand], goals[hand], aims[hand] = self.keep(observation, hand, 0.5 * (sides[0] + sides[1]) + self.lift)
        free = [i for i in range(len(hands)) if held[i] < 0.0]
        if good:  # the free hand goes for the bowel a stride beyond the leading hold, or the
            # nearest stride to it that its shaft reaches (leaning at most base.REACH_DEG)
            lead = max(good, key=lambda i: direction * held[i])
            goers = [i for i in free]
            targets = [float(held[lead]) + direction * stride for stride in self.strides]
        else:  # before the run: the first grasper takes the mark; the others wait
            goers = [i for i in free if i == 0]
            targets = [mark]
        for i in goers:
            points = [self.axis_point(axis, s) for s in targets]
            reached = [q for q in points if shaft_within_reach(self.tools.trocar[hands[i]], q)] or points[:1]
            point = reached[0]
            phases[hands[i]], goals[hands[i]], aims[hands[i]] = self.grasp(observation, hands[i], point)
        leader = next((h for h in hands if phases.get(h) in ("let go", "open")), None) or \
            next((hands[i] for i in goers), None) or hands[0]
        return self.act(observation, goals, phases.get(leader, "hold"), leader, aims)
