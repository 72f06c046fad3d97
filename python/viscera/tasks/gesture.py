"""The clearing gesture: pick the loops lying over the target area and lay them aside.

    python -m viscera play clear_area --seed 0      # one whole episode of it, and whether it succeeded

The oracle of clear_area (viscera.tasks.oracle: every control step, its phase, aims and action
from the observation alone): the axis points, the target and its coverage, gravity, the hold,
the tools' joints and last commands, plus the scene's fixed anatomy (the trocars, the
mesentery's root line, the shortest mesentery of the tasks' range). Each step:

- holding a loop, the grasper carries it where the taut-rope prediction (viscera.tasks.carry)
  leaves most of the target uncovered: `lift` to `carry_height`, `carry` over the drop, `lower`
  to LAY_HEIGHT, `release`;
- holding nothing, while less than `good_enough` (85 %) of the target is uncovered (or less than
  `resume_below`, 80 %, once withdrawn), it goes for the loop to carry: `rise` off the bowel it
  just laid, `approach` the exposed axis point over the target with the best carry, `descend`,
  `close`; a jaw shut on nothing opens (`open`);
- else it `withdraw`s to its trocar with its jaws open (the retractor too), and `rest`s there.

Which loop and where: of the exposed axis points over covered cells (no other loop on them) and
the drops on a fixed grid over the cavity's floor, within the grasper's reach, the pair with the
best score: the uncovered fraction the prediction leaves, plus a bonus for laying the moved rope
clear of the target (up to `clearance_cap`), minus `distance_weight` times the carry's length,
plus `downhill_weight` times its fall along the table's tilt. Carries that would stretch the
bowel to a pinned end or beyond its mesentery are ruled out. The choice is not remembered: the
score of a drop, less the tip's distance to it, stays best while the tip goes to it (and a pick
likewise, less `approach_weight` times the tip's distance), so the same choice is made again
every step from what is observed. The prediction reads only the rope's rest length and the
points it does not move, so it holds while the loop is carried.

Why the taut-rope choice: a loop carried away from where its rope comes from lies taut across
the target and springs back when let go. How often the gesture succeeds is measured, not written
here: docs/tasks/rates.json (python python/tools/task_rates.py).
"""

from __future__ import annotations

import math

import numpy as np

from viscera.numerics import dot, norm, norms
from viscera.tasks import scene
from viscera.tasks.base import GRID, shaft_within_reach
from viscera.tasks.oracle import Decision
from viscera.tasks.policies import JAW_CLOSED_DEG, JAW_OPEN_DEG, JAW_SHUT_DEG, SENT_M, GraspPolicy

TOOLS = ("grasper", "retractor")
LAY_HEIGHT = 0.045  # m above the posterior wall where a carried loop is lowered and let go
TARGET_PATCH_HALF_M = 0.0005  # the target patch's half thickness: its centre is this above the wall
# m between the axis points a carry is planned on (100 on 3 m): a finer observation is resampled
# to them
PLAN_SPACING_M = 0.03
DROP_SPACING_M = 0.02  # m between the drops of the grid over the cavity's floor
LAID_MARGIN_M = 0.025  # m: a held loop low outside the target grown by this is being laid
GIVE_M = 0.007  # m: the most a reaching grasper gives way to a loop pressing on it
WITHDRAWN_M = 0.002  # m: a depth command at most this: the tool is withdrawn to its trocar
LEAVING_HEIGHT_M = 0.10  # m above the wall: a grasper higher, holding nothing, is leaving or gone


def segment_distances2(cells: np.ndarray, start: np.ndarray, end: np.ndarray) -> np.ndarray:
    """Squared distances (m^2) from `cells` (C, 2) to each segment from `start` to `end` (m, (S, 2)
    each): (S, C)."""
    d = end - start
    length2 = np.maximum((d * d).sum(axis=1), 1e-18)
    rel = cells[None, :, :] - start[:, None, :]
    t = np.clip((rel * d[:, None, :]).sum(axis=2) / length2[:, None], 0.0, 1.0)
    off = rel - t[:, :, None] * d[:, None, :]
    return (off * off).sum(axis=2)


class ClearingGesture(GraspPolicy):
    """Oracle for viscera.tasks.load("clear_area"): `decide(observation)`, or call with a dm_env
    TimeStep for the action."""

    PHASES = GraspPolicy.PHASES + ("carry", "lower", "release", "withdraw", "rest")

    def __init__(self, env, carry_height: float = 0.12, good_enough: float = 0.85, resume_below: float = 0.8,
                 carry_distances: tuple[float, float] = (0.05, 0.14), clearance_weight: float = 0.5,
                 clearance_cap: float = 0.08, distance_weight: float = 0.5, downhill_weight: float = 1.0,
                 approach_weight: float = 3.0):
        super().__init__(env)
        physics = env.physics
        self.good_enough = good_enough  # uncovered fraction at which the grasper leaves
        self.resume_below = resume_below  # ... and below which, withdrawn, it comes back for more
        self.carry_height = carry_height  # m above the wall while carrying: higher drags the neighbours up
        self.carry_distances = tuple(carry_distances)  # m: the drops a pick is planned with, from it
        self.clearance_weight, self.clearance_cap = clearance_weight, clearance_cap
        self.distance_weight, self.downhill_weight = distance_weight, downhill_weight
        self.approach_weight = approach_weight  # per m of the tip's distance to a pick
        self.mesentery_reach = scene.MESENTERY_LENGTH[0]
        self.root_line = np.array(physics.intestine().config["mesentery_root"].split(), dtype=float).reshape(2, 3)
        region = np.array(env.task.scene.lay_region)
        xs = np.arange(region[0, 0], region[0, 1] + 1e-9, DROP_SPACING_M)
        ys = np.arange(region[1, 0], region[1, 1] + 1e-9, DROP_SPACING_M)
        grid = np.array([[x, y] for x in xs for y in ys])
        trocar = self.tools.trocar["grasper"]
        self.grid = grid[[shaft_within_reach(trocar, np.append(d, LAY_HEIGHT)) for d in grid]]
        self._drops_key, self._drops = None, None
        self.target_margin = 0.04  # m: drops lie outside the target grown by this
        self.plan_points = int(round(self.rest_length / PLAN_SPACING_M))
        self.cycles = 0  # releases seen (informative: no decision reads it)
        self._cover_key, self._cover = None, None

    # -- the target
    def target_cells(self, observation) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
        """The target's centre and half sizes (m, x y), its sampling points (m, (GRID^2, 2),
        coverage order) and the wall's height under it (m)."""
        target = np.asarray(observation["target"], dtype=float)
        centre, half = target[:2], target[3:5]
        u = (np.arange(GRID) + 0.5) / GRID * 2.0 - 1.0
        x, y = np.meshgrid(centre[0] + u * half[0], centre[1] + u * half[1])
        return centre, half, np.stack([x.ravel(), y.ravel()], axis=1), float(target[2]) - TARGET_PATCH_HALF_M

    def scored(self, observation, cells: np.ndarray) -> np.ndarray:
        """The cells the gesture clears (all of the target's)."""
        return np.ones(len(cells), dtype=bool)

    def uncovered(self, observation) -> float:
        coverage = np.asarray(observation["target_coverage"], dtype=float)
        return 1.0 - float(np.mean(coverage > 0.5))

    # -- the plan
    def plan_axis(self, observation) -> np.ndarray:
        from viscera.tasks import carry
        axis = np.asarray(observation["intestine_axis"], dtype=float).reshape(-1, 3)
        return carry.resampled(axis, self.plan_points) if len(axis) > self.plan_points else axis

    def roots(self, count: int) -> np.ndarray:
        from viscera.tasks import carry
        return carry.mesentery_roots(self.root_line, count)

    def carries(self, axis: np.ndarray, index: int, drops: np.ndarray, cells: np.ndarray, centre, half):
        """For axis point `index` carried to each of `drops` (m, (D, 2)) by the taut-rope
        prediction: which are feasible, and each one's uncovered fraction of `cells` plus the
        clearance bonus. The rope's length is its rest length between the axis points (so a
        carried stretch reads as much rope as before it was carried)."""
        n = len(axis)
        spacing = self.rest_length / (n - 1)
        roots = self.roots(n)
        r2 = self.radius ** 2
        feasible = np.ones(len(drops), dtype=bool)
        anchors = []  # per side: anchor index per drop (-1: no rope on that side)
        moved_points = np.repeat(axis[None, :, :2], len(drops), axis=0)
        moved = np.zeros((len(drops), n), dtype=bool)
        moved[:, index] = True
        moved_points[:, index] = drops
        for step in (-1, 1):
            chain = np.arange(index + step, -1 if step < 0 else n, step)
            if not len(chain):
                anchors.append(np.full(len(drops), -1))
                continue
            lengths = spacing * np.arange(1, len(chain) + 1)
            distance = norms(drops[:, None, :] - axis[chain][None, :, :2])
            hit = lengths[None, :] >= distance
            found = hit.any(axis=1)
            feasible &= found
            first = np.argmax(hit, axis=1)
            anchor = chain[first]
            anchors.append(np.where(found, anchor, -1))
            share = lengths[None, :] / lengths[first][:, None]  # along each drop's leg
            inside = np.arange(len(chain))[None, :] < first[:, None]
            legs = drops[:, None, :] + share[:, :, None] * (axis[anchor][:, None, :2] - drops[:, None, :])
            moved_points[:, chain] = np.where(inside[:, :, None], legs, moved_points[:, chain])
            moved[:, chain] |= inside
        before = norms(axis - roots)
        after = norms(np.concatenate([moved_points, np.broadcast_to(axis[None, :, 2:], (len(drops), n, 1))], axis=2)
                      - roots[None])
        feasible &= ~np.any(moved & (after > np.maximum(before, self.mesentery_reach)[None] + 1e-9), axis=1)
        feasible &= moved.sum(axis=1) > 0
        # coverage after: the segments left where they lie, and the two straight legs from the drop
        prefix, suffix = self.segment_cover(axis, cells)
        left, right = anchors
        covered = np.zeros((len(drops), len(cells)), dtype=bool)
        has_left, has_right = left >= 0, right >= 0
        covered |= np.where(has_left[:, None], prefix[np.maximum(left, 0)], prefix[index])
        covered |= np.where(has_right[:, None], suffix[np.where(has_right, right, n - 1)], suffix[n - 1])
        for anchor, has in ((left, has_left), (right, has_right)):
            ends = axis[np.maximum(anchor, 0), :2]
            covered |= has[:, None] & (segment_distances2(cells, drops, ends) <= r2)
        uncovered = 1.0 - covered.mean(axis=1)
        outside = np.maximum(np.abs(moved_points - centre) - half, 0.0)
        clearance = np.where(moved, norms(outside), np.inf).min(axis=2 - 1)
        bonus = self.clearance_weight * np.minimum(clearance, self.clearance_cap) / self.clearance_cap
        return feasible, uncovered + bonus

    def segment_cover(self, axis: np.ndarray, cells: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Which `cells` the tube's segments 0..k-1 cover (prefix[k]) and k..n-2 (suffix[k]); kept
        for the last axis and cells asked (a cache: the same numbers for the same input)."""
        key = (axis.tobytes(), cells.tobytes())
        if self._cover_key != key:
            seg = segment_distances2(cells, axis[:-1, :2], axis[1:, :2]) <= self.radius ** 2  # (n - 1, C)
            none = np.zeros((1, len(cells)), dtype=bool)
            self._cover = (np.concatenate([none, np.logical_or.accumulate(seg, axis=0)]),
                           np.concatenate([np.logical_or.accumulate(seg[::-1], axis=0)[::-1], none]))
            self._cover_key = key
        return self._cover

    def outside(self, points: np.ndarray, centre, half) -> np.ndarray:
        """Which `points` (m, (k, 2)) lie outside the target grown by `target_margin`."""
        return np.any(np.abs(points - centre) > half + self.target_margin, axis=1)

    def drops(self, observation) -> np.ndarray:
        """The drops (m, (D, 2)): the grid's points where the grasper lowers a loop to LAY_HEIGHT
        over the wall under the target within its actuators' ranges (kept for the last wall
        height asked: the same numbers for the same input)."""
        wall_z = self.target_cells(observation)[3]
        if self._drops_key != wall_z:
            self._drops = self.grid[[self.reaches("grasper", np.append(d, wall_z + LAY_HEIGHT)) for d in self.grid]]
            self._drops_key = wall_z
        return self._drops

    def highest_reach(self, xy: np.ndarray, wall_z: float) -> float:
        """The carry height over `xy` (m): `carry_height` above the wall, or lower, in 1 cm steps, where
        the grasper's working point gets there (a shaft leans more to reach a higher point beside it)."""
        for height in np.arange(self.carry_height, LAY_HEIGHT - 1e-9, -0.01):
            if self.reaches("grasper", np.array([xy[0], xy[1], wall_z + height])):
                return wall_z + float(height)
        return wall_z + LAY_HEIGHT

    def downhill(self, observation) -> np.ndarray:
        """sin(tilt) along the slope, x y: gravity's horizontal part over its size."""
        gravity = np.asarray(observation["gravity"], dtype=float)
        return gravity[:2] / norm(gravity)

    def drop_for(self, observation, axis, index: int, tip: np.ndarray, cells, centre, half):
        """Where to lay axis point `index`, held at `tip` (m): the best drop by its score less
        `distance_weight` times the tip's distance to it (None: nothing feasible)."""
        grid = self.drops(observation)
        near = (norms(grid - tip[:2]) <= self.carry_distances[1] + 0.02) & self.outside(grid, centre, half)
        drops = grid[near]
        if not len(drops):
            return None
        feasible, score = self.carries(axis, index, drops, cells, centre, half)
        score = score - self.distance_weight * norms(drops - tip[:2]) \
            + self.downhill_weight * dot(drops, self.downhill(observation))
        if not feasible.any():
            return None
        return drops[int(np.argmax(np.where(feasible, score, -np.inf)))]

    def exposed_over(self, axis: np.ndarray, cells: np.ndarray, coverage: np.ndarray) -> np.ndarray:
        """Indices of the axis points over a covered cell (as the reward sees it) on which no
        other stretch of the bowel lies."""
        covered = cells[coverage > 0.5]
        if not len(covered):
            return np.zeros(0, dtype=int)
        d2 = ((axis[:, None, :2] - covered[None, :, :]) ** 2).sum(axis=2)
        over = np.flatnonzero(d2.min(axis=1) <= (1.5 * self.radius) ** 2)
        out = self.exposed_among(axis, over)
        return out if len(out) else np.array([int(over[np.argmax(axis[over, 2])])] if len(over) else [], dtype=int)

    def exposed_among(self, axis: np.ndarray, indices: np.ndarray) -> np.ndarray:
        """Those of the axis points `indices` on which no other stretch of the bowel lies."""
        out = []
        for i in indices:
            others = np.abs(np.arange(len(axis)) - i) > 2
            near = norms(axis[:, :2] - axis[i, :2]) < 1.5 * self.radius
            if not np.any(others & near & (axis[:, 2] > axis[i, 2] + self.radius)):
                out.append(int(i))
        return np.array(out, dtype=int)

    def pick(self, observation, axis, tip, cells, centre, half, coverage):
        """The axis point to take (index) and the tip's goal over it: the best pick by its best
        carry less `approach_weight` times the tip's distance to it; None when nothing to take."""
        candidates = self.exposed_over(axis, cells, coverage)
        if not len(candidates):
            return None
        # going down on one: keep it (the nearest exposed point over the target under the tip,
        # covering a cell or not: the coverage flickers while the jaws press on the loop)
        over = np.flatnonzero(np.all(np.abs(axis[:, :2] - centre) <= half + 1.5 * self.radius, axis=1))
        across = norms(axis[over, :2] - tip[:2])
        under = over[(across <= 0.015) & (tip[2] <= axis[over, 2] + 0.05)]
        under = self.exposed_among(axis, under)
        if len(under):
            return int(under[np.argmin(norms(axis[under, :2] - tip[:2]))])
        best, choice = -np.inf, None
        downhill = self.downhill(observation)
        grid = self.drops(observation)
        for index in candidates:
            at = axis[index, :2]
            distance = norms(grid - at)
            ring = (distance >= self.carry_distances[0]) & (distance <= self.carry_distances[1]) \
                & self.outside(grid, centre, half)
            drops = grid[ring]
            if not len(drops):
                continue
            feasible, score = self.carries(axis, int(index), drops, cells, centre, half)
            if not feasible.any():
                continue
            score = score - self.distance_weight * distance[ring] + self.downhill_weight * dot(drops - at, downhill)
            value = float(np.max(np.where(feasible, score, -np.inf))) - self.approach_weight * norm(tip[:2] - at)
            if value > best:
                best, choice = value, int(index)
        if choice is None and len(candidates):  # nothing feasible: the top one, all the same
            choice = int(candidates[int(np.argmax(axis[candidates, 2]))])
        return choice

    # -- the decision
    def withdrawn(self, command: dict) -> bool:
        return command["depth"] <= WITHDRAWN_M

    def done(self, observation, tip: np.ndarray, wall_z: float, over: bool) -> bool:
        """Whether the grasper leaves (or stays away): nothing to take, or `good_enough` of the
        target uncovered, or `resume_below` with the grasper high (leaving, or gone)."""
        uncovered = self.uncovered(observation)
        return not over or uncovered >= self.good_enough or (
            uncovered >= self.resume_below and tip[2] >= wall_z + LEAVING_HEIGHT_M)

    def grasper(self, observation) -> tuple[str, dict, np.ndarray]:
        """The grasper's phase, goal (deg, m) and aim (m)."""
        g = "grasper"
        command, now = self.commands(observation)[g], self.joints(observation)[g]
        tip = self.tip(g, now)
        centre, half, cells, wall_z = self.target_cells(observation)
        cells = cells[self.scored(observation, cells)]
        coverage = np.asarray(observation["target_coverage"], dtype=float)[self.scored(observation, self.target_cells(observation)[2])]
        axis = self.plan_axis(observation)
        holding = float(np.asarray(observation["grasper_holding"])[0]) > 0.5
        if holding:
            sent = self.tip(g, command)  # where it was sent: the tip is pushed about by the loops it carries over
            held = float(np.asarray(observation["held_abscissa"])[0])
            index = int(round(min(1.0, max(0.0, held / self.rest_length)) * (len(axis) - 1)))
            drop = self.drop_for(observation, axis, index, sent, cells, centre, half)
            if drop is None:  # nothing feasible: straight out of the target, away from its centre
                away = sent[:2] - centre
                drop = sent[:2] + 0.08 * away / max(norm(away), 1e-9)
            lowered = np.array([drop[0], drop[1], wall_z + LAY_HEIGHT])
            goal = self.at(g, lowered, JAW_CLOSED_DEG)
            # out of the target (grown by LAID_MARGIN_M: picks lie within it) and low, or sent as
            # low as it goes there: a loop being laid
            outside = bool(np.any(np.abs(sent[:2] - centre) > half + LAID_MARGIN_M))
            laid = outside and (tip[2] <= wall_z + LAY_HEIGHT + 0.01 or norm(sent - self.tip(g, goal)) <= SENT_M)
            if now["jaw"] > JAW_SHUT_DEG and command["jaw"] > JAW_CLOSED_DEG + 0.5 and not laid:
                return "close", dict(command, jaw=JAW_CLOSED_DEG), tip
            # over the drop at the carry height, or on at the command's height once out of the
            # target and lower; out of reach, as near over it as the tool goes
            top = self.highest_reach(drop, wall_z)
            height = min(sent[2], top) if outside else top
            carry_aim = np.array([drop[0], drop[1], height])
            carry_goal = self.over(g, carry_aim, JAW_CLOSED_DEG)
            across = norm(sent[:2] - self.tip(g, carry_goal)[:2])
            if laid and command["jaw"] > JAW_CLOSED_DEG + 0.5:  # letting go
                return "release", dict(command, jaw=JAW_OPEN_DEG), lowered
            if across > 0.015:
                # up first, off the other loops, to the height it is carried at
                if sent[2] < top - 0.04 and not outside:
                    aim = np.array([sent[0], sent[1], top])
                    return "lift", self.over(g, aim, JAW_CLOSED_DEG), aim
                return "carry", carry_goal, carry_aim
            if not laid:
                return "lower", goal, lowered
            return "release", dict(goal, jaw=JAW_OPEN_DEG), lowered
        over = self.exposed_over(axis, cells, coverage)
        if self.done(observation, tip, wall_z, bool(len(over))) and command["jaw"] >= JAW_OPEN_DEG - 0.5:
            goal = dict(command, depth=0.0, jaw=JAW_OPEN_DEG)
            return ("rest" if self.withdrawn(command) else "withdraw"), goal, self.tip(g, goal)
        if self.done(observation, tip, wall_z, bool(len(over))):
            return "open", dict(command, jaw=JAW_OPEN_DEG), tip
        # the pick from where the grasper was sent (its command moves smoothly; the tip is pushed about)
        index = self.pick(observation, axis, self.tip(g, command), cells, centre, half, coverage)
        return self.grasp(observation, g, axis[index])

    def retractor(self, observation, grasper_phase: str) -> tuple[dict | None, np.ndarray | None]:
        """The retractor's goal and aim: it withdraws with the grasper, else holds."""
        if grasper_phase in ("withdraw", "rest"):
            command = self.commands(observation)["retractor"]
            goal = dict(command, depth=0.0)
            return goal, self.tip("retractor", goal)
        return None, None

    def decide(self, observation) -> Decision:
        phase, goal, aim = self.grasper(observation)
        goals, aims = {"grasper": goal}, {"grasper": aim}
        r_goal, r_aim = self.retractor(observation, phase)
        if r_goal is not None:
            goals["retractor"], aims["retractor"] = r_goal, r_aim
        if phase == "release" and (self.last is None or self.last.phase != "release"):
            self.cycles += 1
        return self.act(observation, goals, phase, "grasper", aims)


class RetractReachGesture(ClearingGesture):
    """Oracle for retract_reach: the clearing gesture on the working spot (the target's sampling
    points within `spot` m of its centre); the retractor holds down the loop nearest the target's
    centre outside the spot (or, while the grasper pushes on a loop at the centre, the loop
    nearest the grasper's shaft), its paddle along the bowel, and keeps pressing what it presses;
    once the spot is clear, the grasper comes down on the target's centre with its jaws open
    (`reach over`, `reach`) and stays while the centre is uncovered; a grasper pushing harder
    than `push_force` on a loop rises and comes down again once the retractor holds that loop."""

    PHASES = ClearingGesture.PHASES + ("reach over", "reach")

    def __init__(self, env, spot: float = 0.004, centre_radius: float = 0.004, press_force: float = 0.05,
                 push_force: float = 0.5, reach_height: float = 0.002, retract_gap: float = 0.015,
                 press_height_over: float = 0.0, **kwargs):
        self.spot = spot  # m
        self.centre_radius = centre_radius  # m: the coverage cells that make the target's centre
        self.press_force = press_force  # N: the retractor presses when its sensor reads this
        self.push_force = push_force  # N: the grasper pushes on a loop above this
        self.reach_height = reach_height  # m: the tip's goal above the wall at the target's centre
        self.retract_gap = retract_gap  # m beyond the spot where the retractor holds the nearest loop
        self.press_height_over = press_height_over  # m: the paddle this far above the held loop's top
        kwargs = dict(dict(good_enough=1.0, resume_below=1.0, carry_height=0.07), **kwargs)
        super().__init__(env, **kwargs)

    def scored(self, observation, cells: np.ndarray) -> np.ndarray:
        target = np.asarray(observation["target"], dtype=float)
        return norms(cells - target[:2]) <= self.spot

    def spot_clear(self, observation) -> bool:
        _, _, cells, _ = self.target_cells(observation)
        coverage = np.asarray(observation["target_coverage"], dtype=float)
        return not np.any(coverage[self.scored(observation, cells)] > 0.5)

    def grasper(self, observation) -> tuple[str, dict, np.ndarray]:
        g = "grasper"
        command, now = self.commands(observation)[g], self.joints(observation)[g]
        holding = float(np.asarray(observation["grasper_holding"])[0]) > 0.5
        centre, half, cells, wall_z = self.target_cells(observation)
        # a covered spot with no loop over it to take (what covers it lies under others): reach all the same
        takeable = len(self.exposed_over(self.plan_axis(observation), cells[self.scored(observation, cells)],
                                         np.asarray(observation["target_coverage"], dtype=float)[self.scored(observation, cells)]))
        # at the centre, what counts is the task's own test (no tube within its radius of the centre),
        # not the spot's coverage cells, which flicker as the jaws press on the loops around them
        sent = self.tip(g, command)
        at_centre = norm(sent[:2] - centre) <= 0.01 and sent[2] <= wall_z + 0.02
        covered = self.centre_covered(observation, centre) if at_centre else not self.spot_clear(observation)
        if holding or (covered and takeable) or command["jaw"] < JAW_OPEN_DEG - 0.5:
            phase, goal, aim = super().grasper(observation)
            return phase, goal, aim
        tip = self.tip(g, now)
        reach = np.append(centre, wall_z + self.reach_height)
        forces = np.asarray(observation["tool_forces"], dtype=float)
        pushing = norm(forces[0:3]) > self.push_force
        # a loop pressing on the jaws at the centre: the tip gives way along the force, up to
        # GIVE_M (the reach counts within 1 cm), more the harder it is pushed
        give = GIVE_M * min(1.0, max(0.0, (norm(forces[0:3]) - 0.3 * self.push_force) / (0.4 * self.push_force)))
        reach = reach + give * forces[0:3] / max(norm(forces[0:3]), 1e-9)
        if pushing and not self.pressing(observation):  # wait up for the retractor to hold that loop
            aim = np.array([tip[0], tip[1], wall_z + 0.05])
            return "rise", self.at(g, aim, JAW_OPEN_DEG), aim
        if norm(tip[:2] - centre) > 0.01 and tip[2] < wall_z + 0.04:
            aim = np.array([tip[0], tip[1], wall_z + 0.05])
            return "rise", self.at(g, aim, JAW_OPEN_DEG), aim
        if norm(tip[:2] - centre) > 0.01:
            aim = reach + np.array([0.0, 0.0, 0.05])
            return "reach over", self.at(g, aim, JAW_OPEN_DEG), aim
        return "reach", self.at(g, reach, JAW_OPEN_DEG), reach

    def centre_covered(self, observation, centre: np.ndarray) -> bool:
        """Some of the tube lies over the target's centre (m, x y): an axis segment within its radius."""
        axis = np.asarray(observation["intestine_axis"], dtype=float).reshape(-1, 3)[:, :2]
        return bool(np.any(segment_distances2(centre[None, :], axis[:-1], axis[1:]) <= self.radius ** 2))

    def pressing(self, observation) -> bool:
        forces = np.asarray(observation["tool_forces"], dtype=float)
        return norm(forces[6:9]) >= self.press_force

    def retractor(self, observation, grasper_phase: str) -> tuple[dict | None, np.ndarray | None]:
        """The retractor holds down the loop nearest the target's centre outside the spot (or,
        while the grasper pushes at the centre, the one nearest its shaft), on its top, its paddle
        along the bowel; pressing, it stays."""
        r = "retractor"
        if self.pressing(observation):
            return None, None
        axis = np.asarray(observation["intestine_axis"], dtype=float).reshape(-1, 3)
        centre, _, _, wall_z = self.target_cells(observation)
        distance = norms(axis[:, :2] - centre)
        outside = np.flatnonzero(distance > self.spot + self.retract_gap)
        if not len(outside):
            return None, None
        nearness = distance
        forces = np.asarray(observation["tool_forces"], dtype=float)
        if norm(forces[0:3]) > self.push_force and grasper_phase in ("reach", "rise"):
            tip = np.append(centre, wall_z + self.reach_height)
            shaft = self.tools.trocar["grasper"] - tip
            shaft = shaft / norm(shaft)
            along = np.clip(dot(axis - tip, shaft), 0.0, 0.06)
            nearness = norms(axis - (tip + along[:, None] * shaft))
        index = int(outside[np.argmin(nearness[outside])])
        tangent = axis[min(index + 1, len(axis) - 1), :2] - axis[max(index - 1, 0), :2]
        roll = math.degrees(math.atan2(float(tangent[1]), float(tangent[0])))
        roll = (roll + 90.0) % 180.0 - 90.0  # the paddle is symmetric: the shorter turn
        command = self.commands(observation)[r]
        tip = self.tip(r, self.joints(observation)[r])
        point = axis[index]
        press = np.array([point[0], point[1], point[2] + self.radius + self.press_height_over])
        if norm(tip[:2] - point[:2]) > 0.015:  # over it first, from above
            over = np.array([point[0], point[1], max(press[2] + 0.03, tip[2])])
            return self.at(r, over, 0.0, roll), over
        del command
        return self.at(r, press, 0.0, roll), press

    def decide(self, observation) -> Decision:
        phase, goal, aim = self.grasper(observation)
        goals, aims = {"grasper": goal}, {"grasper": aim}
        r_goal, r_aim = self.retractor(observation, phase)
        if r_goal is not None:
            goals["retractor"], aims["retractor"] = r_goal, r_aim
        lead = "grasper"
        return self.act(observation, goals, phase, lead, aims)
