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


import numpy as np

from viscera.numerics import norm, norms
from viscera.tasks.base import shaft_within_reach
from viscera.tasks.oracle import JAW_CLOSED_DEG, JAW_OPEN_DEG, LIMITS, Decision, Oracle, Tools  # noqa: F401

CLEARANCE_M = 0.04      # the open jaws come this far above the point they go for
NEAR_M = 0.01           # the tip this close to the point horizontally is over it
LOW_M = 0.02            # a tip lower than this above the point, and farther than FAR_M, rises first
FAR_M = 0.025
JAW_SHUT_DEG = 1.0      # a jaw at or under this has shut (on nothing, if it holds nothing)
CROWDED_M = 0.03      # m: bowel this close (across) to another jaw's tip is left to it
RETRY_M = 0.02        # m: an opening tool's command is drawn up this far ahead of where it was sent
PULL_STEP_M = 0.02    # m: a hold drawn across is aimed this far ahead of where it was sent
SENT_M = 0.005          # a command whose working point is this close to the goal's has been sent there
COMMAND_AT_DEG = 0.3    # a command this close to its goal's angles ...
COMMAND_AT_M = 0.0015   # ... and depth has arrived


class GraspPolicy(Oracle):
    """What the grasping oracles share: the phases of one grasp, from the state."""

    PHASES = ("approach", "rise", "descend", "close", "open", "let go", "lift", "hold", "pull")
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
        """The phase, the goal (deg, m) and the aim (m) of `tool`, free, going for `point` (m).

        Where the tool is going is read from its last command (`sent`), not from where the tip
        is: the command moves smoothly under the oracle's own rule, while the tip is pushed about
        by the bowel it touches, so tests on the command do not flicker."""
        command, now = self.commands(observation)[tool], self.joints(observation)[tool]
        tip, sent = self.tip(tool, now), self.tip(tool, command)
        point = np.asarray(point, dtype=float)
        grip = point - np.array([0.0, 0.0, self.grip_below])
        if command["jaw"] < JAW_OPEN_DEG - 0.5:  # the jaws are not (yet) open, holding nothing
            # closing where they were sent to grip (the command leads the jaw down) goes on; opening
            # (the command leads the jaw up, or it shut on nothing) draws the tool back along its
            # shaft meanwhile, so that the next try comes down on the point afresh
            closing = command["jaw"] <= now["jaw"] + JAW_SHUT_DEG and now["jaw"] > JAW_SHUT_DEG \
                and norm(sent - self.tip(tool, self.at(tool, grip, JAW_CLOSED_DEG))) <= 2.0 * SENT_M
            if closing:
                return "close", dict(command, jaw=JAW_CLOSED_DEG), tip  # where they are: no chasing
            back = np.array([sent[0], sent[1], sent[2] + RETRY_M])
            return "open", self.at_height(tool, dict(command, jaw=JAW_OPEN_DEG), back[2]), back
        # over the point at its clearance, or at the command's height if higher: no dip on the way
        above = np.array([point[0], point[1], max(point[2] + CLEARANCE_M, sent[2])])
        approach = self.over(tool, above, JAW_OPEN_DEG)
        across = norm((sent - point)[:2])
        # over the point, or as near it as the tool reaches; going down, within a wider circle
        near = NEAR_M + norm((self.tip(tool, approach) - above)[:2])
        if across > near and not (across <= near + NEAR_M and sent[2] < above[2] - NEAR_M):
            if across > FAR_M and (sent[2] < point[2] + LOW_M or self.near_bowel(observation, sent)):
                # up first, straight along the shaft: a tip low among the loops drags them along
                return "rise", self.at_height(tool, dict(command, jaw=JAW_OPEN_DEG), sent[2] + CLEARANCE_M), \
                    np.array([sent[0], sent[1], sent[2] + CLEARANCE_M])
            return "approach", approach, above
        goal = self.at(tool, grip, JAW_OPEN_DEG)
        # the jaws close once sent there (a bowel pushed ahead of them is followed: the command
        # is then at most SENT_M behind the moving goal), wherever the bowel stopped them
        if norm(sent - self.tip(tool, goal)) > SENT_M:
            return "descend", goal, grip
        return "close", self.at(tool, grip, JAW_CLOSED_DEG), grip

    def over(self, tool: str, point, jaw: float) -> dict:
        """Tool coordinates (deg, m) that put `tool`'s working point over `point` (m) at its height,
        or, out of reach, as near over it as the angles' ranges let it, still at its height (a
        clipped aim would otherwise come in lower than asked, onto the loops)."""
        goal = self.at(tool, point, jaw)
        if abs(self.tip(tool, goal)[2] - float(point[2])) > 1e-3:
            goal = self.at_height(tool, goal, float(point[2]))
        return goal

    def reaches(self, tool: str, point) -> bool:
        """Whether `tool`'s working point gets within SENT_M of `point` (m) inside its actuators' ranges."""
        return norm(self.tip(tool, self.at(tool, point, JAW_OPEN_DEG)) - np.asarray(point, dtype=float)) <= SENT_M

    def near_bowel(self, observation, tip: np.ndarray) -> bool:
        """Some of the bowel lies just under the tip (within FAR_M across, its axis at most LOW_M below)."""
        axis = np.asarray(observation["intestine_axis"], dtype=float).reshape(-1, 3)
        across = ((axis[:, :2] - tip[:2]) ** 2).sum(axis=1)
        below = tip[2] - axis[:, 2]
        return bool(np.any((across < FAR_M ** 2) & (below > -self.radius) & (below < LOW_M)))

    def keep(self, observation, tool: str, height: float, toward=None) -> tuple[str, dict, np.ndarray]:
        """`tool`, holding, raised along its shaft to `height` (m) and kept there, jaws shut; with
        `toward` (m, a point), drawn across towards it at PULL_SPEED meanwhile (`pull`)."""
        command, now = self.commands(observation)[tool], self.joints(observation)[tool]
        if now["jaw"] > JAW_SHUT_DEG:  # still closing: the pinch builds before the pull
            return "close", dict(command, jaw=JAW_CLOSED_DEG), self.tip(tool, now)
        goal = self.at_height(tool, dict(command, jaw=JAW_CLOSED_DEG), height)
        if toward is not None:
            sent = self.tip(tool, command)
            way = np.asarray(toward, dtype=float)[:2] - sent[:2]
            aim = np.append(sent[:2] + PULL_STEP_M * way / max(norm(way), 1e-9), height)
            return "pull", self.over(tool, aim, JAW_CLOSED_DEG), aim
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

    def next_grip(self, observation, axis: np.ndarray, hands: list, i: int, targets: list) -> tuple[np.ndarray, bool]:
        """Where free hand `i` takes the bowel, of the axis points at `targets` (m along it), and
        whether it reaches it: of those its shaft reaches (leaning at most base.REACH_DEG, within
        its actuators' ranges), the one nearest where the hand was sent, less a preference for the
        first target; one under other bowel or within CROWDED_M of another jaw (going down there
        knocks its hold out) only if nothing else. Nearest where the hand was sent: a choice that
        stays best while the hand goes to it."""
        points = np.array([self.axis_point(axis, s) for s in targets])
        hand = hands[i]
        sent = self.tip(hand, self.commands(observation)[hand])
        reached = np.array([shaft_within_reach(self.tools.trocar[hand], q)
                            and self.reaches(hand, q - [0.0, 0.0, self.grip_below]) for q in points])
        others = np.array([self.tip(h, self.joints(observation)[h]) for h in hands if h != hand])
        crowded = np.array([bool(np.any(norms(others[:, :2] - q[:2]) < CROWDED_M)) for q in points])
        covered = np.array([not self.exposed(axis, q, t) for q, t in zip(points, targets)])
        score = norms(points - sent) + np.abs(np.asarray(targets) - targets[0]) + np.where(reached, 0.0, 1.0) \
            + np.where(crowded, 0.5, 0.0) + np.where(covered, 0.25, 0.0)
        best = int(np.argmin(score))
        return points[best], bool(reached[best])

    def decide(self, observation) -> Decision:
        hands = [t for t in self.names if t.startswith("grasper")]
        held = np.asarray(observation["held_abscissa"], dtype=float)
        counted = np.asarray(observation["counted_abscissa"], dtype=float)
        mark = float(observation["start_mark"][3])
        direction = 1.0 if mark < 0.5 * float(observation["intestine_length"][0]) else -1.0
        axis = np.asarray(observation["intestine_axis"], dtype=float).reshape(-1, 3)
        good = [i for i in range(len(hands)) if held[i] >= 0.0 and counted[i] >= 0.0]
        free = [i for i in range(len(hands)) if held[i] < 0.0]
        phases, goals, aims = {}, {}, {}
        lead = max(good, key=lambda i: direction * held[i]) if good else None
        if good:  # the free hand goes for the bowel a stride beyond the leading hold
            goers = free
            targets = [float(held[lead]) + direction * stride for stride in self.strides]
        else:  # before the run: a grasper that reaches the mark takes it (the first such); the others wait
            reach = [i for i in free if self.reaches(hands[i], self.axis_point(axis, mark) - [0.0, 0.0, self.grip_below])]
            goers = reach[:1] or [i for i in free if i == 0]
            targets = [mark]
        pull_towards = None  # where the leading hold is drawn, when the free hand reaches no stride
        for i in goers:
            point, reachable = self.next_grip(observation, axis, hands, i, targets)
            if reachable or lead is None:
                phases[hands[i]], goals[hands[i]], aims[hands[i]] = self.grasp(observation, hands[i], point)
            else:  # nothing it reaches: it waits over the bowel while the leading hold is drawn its way
                above = point + [0.0, 0.0, CLEARANCE_M]
                phases[hands[i]], goals[hands[i]], aims[hands[i]] = "approach", self.over(hands[i], above, JAW_OPEN_DEG), above
                pull_towards = self.tools.trocar[hands[i]]
        trailing = min(good, key=lambda i: direction * held[i]) if len(good) == 2 else None
        for i, hand in enumerate(hands):
            if held[i] >= 0.0 and (counted[i] < 0.0 or i == trailing):
                phases[hand], goals[hand], aims[hand] = self.let_go(observation, hand)
            elif held[i] >= 0.0:
                s = float(held[i])
                sides = [self.axis_point(axis, s + d)[2] for d in (-0.08, 0.08)]
                height = 0.5 * (sides[0] + sides[1]) + self.lift
                toward = pull_towards if i == lead else None
                phases[hand], goals[hand], aims[hand] = self.keep(observation, hand, height, toward)
        leader = next((h for h in hands if phases.get(h) in ("let go", "open")), None) or \
            next((hands[i] for i in goers), None) or hands[0]
        return self.act(observation, goals, phases.get(leader, "hold"), leader, aims)
