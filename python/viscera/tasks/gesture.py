"""The clearing gesture: pick the loops lying over the target area and lay them aside.

    python -m viscera play clear_area --seed 0      # one whole episode of it, and whether it succeeded

A closed-loop scripted policy for the clear_area task (dm_control convention:
``action = policy(time_step)``), built from the observations alone (the axis
points, the target, its coverage, gravity) and the scene's fixed anatomy (the
trocars, the mesentery's root line, the shortest mesentery of the tasks' range);
it plays smooth, velocity-limited tool trajectories (viscera.trajectory), each
phase lasting as long as its moves need. Each cycle, while less than
`good_enough` (85 %) of the target is uncovered, it plans one carry with the
taut-rope prediction of viscera.tasks.carry: of the exposed axis points over the
target (no other loop on them) and the places around each where it could lay
them, the pair that leaves the most of the target uncovered, with the moved rope
laid clear of the target, short carries and no climbing preferred; carries that would
stretch the bowel to a pinned end or beyond its mesentery are ruled out (the
tissue pulls such a loop straight back). Then: the open grasper above the point,
descend, close (the plugin takes hold of the nearest axis point), lift, carry,
lower, release, and rise to `rise` above the wall before moving on (withdrawing
along the shaft dragged the laid loop back). When the target is uncovered enough, or nothing covers it, or
the time is nearly up, the grasper withdraws to its trocar with its jaws open,
and comes back if less than `resume_below` (80 %) is uncovered. With `press`
the retractor presses each laid loop down (off for clear_area: it did worse).
`RetractReachGesture` is the same gesture on retract_reach's working spot, then
the retraction and the reach.

Why the taut-rope choice: a loop carried away from where its rope comes from lies
taut across the target and springs back when let go. How often the gesture
succeeds is measured, not written here: docs/tasks/rates.json
(python python/tools/task_rates.py).
"""

from __future__ import annotations

import math

import numpy as np

from viscera.numerics import dot, norm, norms
from viscera.tasks import carry, scene
from viscera.tasks.base import GRID, shaft_within_reach
from viscera.tasks.policies import JAW_CLOSED_DEG, JAW_OPEN_DEG, LIMITS, Tools
import dataclasses


@dataclasses.dataclass
class Phase:
    name: str
    duration: float
    moves: dict
from viscera.trajectory import COORDINATES, ToolTrajectory

TOOLS = ("grasper", "retractor")
LAY_HEIGHT = 0.045  # m above the posterior wall where a carried loop is lowered and let go
TARGET_PATCH_HALF_M = 0.0005  # the target patch's half thickness: its centre is this above the wall
# m between the axis points a carry is planned on (100 on 3 m): a finer observation is resampled
# to them, since a plan costs 34 ms on 100 points and 1.8 s on 1000
PLAN_SPACING_M = 0.03


def _phase(name: str, duration: float, grasper: ToolTrajectory, retractor: ToolTrajectory) -> Phase:
    """A phase of both tools' moves (viscera.tasks.policies.Phase)."""
    return Phase(name, duration, {"grasper": grasper, "retractor": retractor})


class ClearingGesture:
    """Policy for viscera.tasks.load("clear_area"): call with a dm_env TimeStep, get an action."""

    cycle_duration = 4.4  # s, one pick, lay and rise

    def __init__(self, env, withdraw_at: float | None = None, carry_height: float = 0.12,
                 good_enough: float = 0.85, resume_below: float = 0.8, press: bool = False, press_beyond: float = 0.02,
                 press_height: float = 0.025, rise: float = 0.1, directions: int = 16,
                 carry_distances: tuple[float, ...] = (0.05, 0.08, 0.11, 0.14), clearance_weight: float = 0.5,
                 clearance_cap: float = 0.08, distance_weight: float = 0.5, uphill_weight: float = 2.0):
        physics = env.physics
        self.control_timestep = env.control_timestep()
        # s: then the tools leave, whatever remains (default: 6 s before the episode's time limit)
        limit = env.time_limit_s  # viscera.tasks.base.Environment's
        self.withdraw_at = withdraw_at if withdraw_at is not None else (limit - 6.0 if np.isfinite(limit) else 24.0)
        self.good_enough = good_enough  # uncovered fraction at which the grasper leaves
        self.resume_below = resume_below  # ... and below which, withdrawn, it comes back for more
        # the retractor presses each laid loop down, press_beyond (m) past where the grasper let it
        # go, its paddle press_height (m) above the wall, so that it does not slide back
        self.press, self.press_beyond, self.press_height = press, press_beyond, press_height
        self.rise = rise  # m above the wall the open jaws rise to, straight up, after a release (0: no rise)
        # where to lay each loop: `directions` around the pick, `carry_distances` (m) from it; the
        # score's weights: clearance (per its cap, m), carry length (per m), climb (per m x sin tilt)
        self.directions, self.carry_distances = directions, tuple(carry_distances)
        self.clearance_weight, self.clearance_cap = clearance_weight, clearance_cap
        self.distance_weight, self.uphill_weight = distance_weight, uphill_weight
        # a carried point stays within the shortest mesentery of its root (anatomy: the root line
        # is the scene's, m, from and to; the depth the least of the tasks' range)
        self.mesentery_reach = scene.MESENTERY_LENGTH[0]
        self.root_line = np.array(physics.intestine().config["mesentery_root"].split(), dtype=float).reshape(2, 3)
        # m above the posterior wall while carrying: a loop lifted higher drags its neighbours up
        # and they slide back
        self.carry_height = carry_height
        # m, x y: where loops may be laid, the scene's floor inside its walls (and its colon)
        region = np.array(env.task.scene.lay_region)
        self.lay_low, self.lay_high = region[:, 0], region[:, 1]
        self.tools = Tools(env)  # trocars, working points, actuators
        self.coordinates = self.tools.coordinates
        self.radius = physics.intestine().radius
        self.plan_points = int(round(physics.intestine().rest_length / PLAN_SPACING_M))
        self.target(np.concatenate([physics.target(), [0.0, 0.0, -9.81]]))
        self._reset()

    def target(self, observation: np.ndarray) -> None:
        """The episode's target and gravity, from the observations `target` (centre m, half sizes
        m) and `gravity` (m/s^2), concatenated."""
        self.centre, self.half = observation[:2].copy(), observation[3:5].copy()
        # m: the posterior wall's height under the target (its patch's centre lies its half
        # thickness, TARGET_PATCH_HALF_M, above the wall; 0 in the box abdomen)
        self.wall_z = float(observation[2]) - TARGET_PATCH_HALF_M
        u = (np.arange(GRID) + 0.5) / GRID * 2.0 - 1.0
        x, y = np.meshgrid(self.centre[0] + u * self.half[0], self.centre[1] + u * self.half[1])
        self.cells = np.stack([x.ravel(), y.ravel()], axis=1)  # the reward's sampling points, coverage order
        self.scored = np.ones(len(self.cells), dtype=bool)  # the cells a carry is scored on
        self.gravity = observation[5:8].copy()

    def _reset(self) -> None:
        self.phases: list[Phase] = []
        self.phase_time = 0.0
        self.time = 0.0
        self.command = {t: {c: 0.0 for c in COORDINATES} for t in TOOLS}
        self.cycles = 0
        self.done = False
        self.pressing: np.ndarray | None = None  # where the retractor presses (m, x y)
        self.observation: dict = {}  # the latest, as __call__ received it

    def _move(self, tool: str, goal: dict, duration: float) -> ToolTrajectory:
        start = dict(self.command[tool])
        self.command[tool] = dict(goal)
        return ToolTrajectory([dict(start, time=0.0), dict(goal, time=duration)], LIMITS)

    def _hold(self, tool: str) -> ToolTrajectory:
        return ToolTrajectory([dict(self.command[tool], time=0.0)], LIMITS)

    def _plan(self, axis: np.ndarray, coverage: np.ndarray) -> None:
        """Queue the phases of the next cycle from the axis points (m, (k, 3)) and the target's
        coverage grid."""
        if len(axis) > self.plan_points:
            axis = carry.resampled(axis, self.plan_points)
        over = self._over_covered_cells(axis, coverage)
        uncovered = 1.0 - float(np.mean(np.asarray(coverage) > 0.5))
        if self.time + self.cycle_duration > self.withdraw_at or not over.any() or uncovered >= self.good_enough:
            self._plan_withdraw()
            return
        index, drop_xy, side = self._choose(axis, over)
        pick = axis[index]
        above = np.array([pick[0], pick[1], pick[2] + 0.04])
        grip = np.array([pick[0], pick[1], pick[2] - 0.3 * self.radius])
        lifted = np.array([pick[0], pick[1], self.carry_height])
        carried = np.array([drop_xy[0], drop_xy[1], self.carry_height])
        lowered = np.array([drop_xy[0], drop_xy[1], LAY_HEIGHT])
        g, r = "grasper", "retractor"
        hold_r = self._hold(r)
        self.phases += [
            _phase("approach", 0.9, self._move(g, self.coordinates(g, above, JAW_OPEN_DEG), 0.8), hold_r),
            _phase("descend", 0.5, self._move(g, self.coordinates(g, grip, JAW_OPEN_DEG), 0.4), hold_r),
            _phase("close", 0.3, self._move(g, self.coordinates(g, grip, JAW_CLOSED_DEG), 0.25), hold_r),
            _phase("lift", 0.6, self._move(g, self.coordinates(g, lifted, JAW_CLOSED_DEG), 0.5), hold_r),
            _phase("carry", 0.9, self._move(g, self.coordinates(g, carried, JAW_CLOSED_DEG), 0.8), hold_r),
            _phase("lower", 0.4, self._move(g, self.coordinates(g, lowered, JAW_CLOSED_DEG), 0.3), hold_r),
        ]
        if self.press:  # the retractor leaves the last laid loop, comes over this one and presses it down
            self._press_at(drop_xy + side * self.press_beyond, self.press_height)
            hold_r = self._hold(r)
        self.phases.append(
            _phase("release", 0.3, self._move(g, self.coordinates(g, lowered, JAW_OPEN_DEG), 0.25), hold_r))
        if self.rise:
            self.phases.append(_phase("rise", 0.5, self._move(
                g, self.coordinates(g, np.append(drop_xy, self.rise), JAW_OPEN_DEG), 0.45), self._hold(r)))
        self.cycles += 1

    def _press_at(self, point: np.ndarray, height: float, roll: float = 0.0) -> None:
        """Queue the retractor's move, the grasper holding: up off what it pressed, over `point`
        (m, x y), down to `height` (m above the wall), its paddle turned `roll` (deg) about the shaft."""
        g, r = "grasper", "retractor"
        hold_g = self._hold(g)
        if self.pressing is not None:
            self.phases.append(_phase("retractor up", 0.4, hold_g, self._move(
                r, self.coordinates(r, np.append(self.pressing, 0.07), roll=self.command[r]["roll"]), 0.35)))
        self.phases += [
            _phase("retractor over", 0.6, hold_g, self._move(r, self.coordinates(r, np.append(point, 0.07), roll=roll),
                                                            0.55)),
            _phase("retractor press", 0.4, hold_g, self._move(r, self.coordinates(r, np.append(point, height),
                                                                                 roll=roll), 0.35))]
        self.pressing = np.asarray(point, dtype=float)

    def _choose(self, axis: np.ndarray, over: np.ndarray) -> tuple[int, np.ndarray, np.ndarray]:
        """The axis point to pick (index), where to lay it (m, xy) and the direction it goes (unit,
        xy): of the exposed points over the covered cells (no other loop on them) and the drops
        around each (`directions` x `carry_distances`, inside the cavity, within the grasper's
        reach), the best by the taut-rope prediction (viscera.tasks.carry): the uncovered
        fraction it leaves, plus a bonus for laying the moved rope clear of the target (up to
        `clearance_cap`: a loop laid beside the hole it left rolls back in), minus the carry's
        length and its climb against the table's tilt."""
        candidates = [int(i) for i in np.flatnonzero(over) if self._exposed(axis, i)] or \
            [int(np.flatnonzero(over)[np.argmax(axis[over, 2])])]
        downhill = np.asarray(self.gravity[:2]) / norm(self.gravity)  # sin(tilt) along the slope
        roots = carry.mesentery_roots(self.root_line, len(axis))
        angles = np.arange(self.directions) * 2.0 * np.pi / self.directions
        directions = np.array([[math.cos(angle), math.sin(angle)] for angle in angles.tolist()])
        best, choice = -np.inf, None
        for index in candidates:
            pick = axis[index, :2]
            for direction in directions:
                for distance in self.carry_distances:
                    drop = np.clip(pick + direction * distance, self.lay_low, self.lay_high)
                    if not shaft_within_reach(self.tools.trocar["grasper"], np.append(drop, LAY_HEIGHT)):
                        continue
                    points = carry.carried(axis, index, drop, roots, self.mesentery_reach)
                    if points is None:
                        continue
                    moved = np.any(points != axis[:, :2], axis=1)
                    if not moved.any():  # the cavity's bounds left it where it was
                        continue
                    score = (1.0 - float(np.mean(carry.covered(points, self.cells[self.scored], self.radius)))
                             + self.clearance_weight * min(carry.clearance(points[moved], self.centre, self.half),
                                                           self.clearance_cap) / self.clearance_cap
                             - self.distance_weight * norm(drop - pick)
                             - self.uphill_weight * max(0.0, -dot(drop - pick, downhill)))
                    if score > best:
                        best, choice = score, (index, drop, (drop - pick) / max(norm(drop - pick), 1e-9))
        if choice is None:  # nothing feasible: the top loop, through the target's nearest edge
            index = candidates[int(np.argmax(axis[candidates, 2]))]
            side = self._exit_side(axis, index)
            drop = axis[index, :2] + side * (self._exit_distance(axis[index, :2], side) + self.clearance_cap)
            return index, np.clip(drop, self.lay_low, self.lay_high), side
        return choice

    def _exposed(self, axis: np.ndarray, index: int) -> bool:
        """No other stretch of the bowel lies on axis point `index` (its jaws would take that one)."""
        others = np.abs(np.arange(len(axis)) - index) > 2
        near = norms(axis[:, :2] - axis[index, :2]) < 1.5 * self.radius
        return not np.any(others & near & (axis[:, 2] > axis[index, 2] + self.radius))

    def _exit_side(self, axis: np.ndarray, index: int) -> np.ndarray:
        """The direction (unit, xy) out of the target through its nearest edge from axis point
        `index`, never uphill (the fallback when no carry is feasible)."""
        offset = axis[index, :2] - self.centre
        margins = np.concatenate([self.half - offset, self.half + offset])  # to the +x, +y, -x, -y edges
        normals = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]])
        uphill = dot(normals, self.gravity[:2]) < -0.05 * norm(self.gravity)
        if uphill.all():
            uphill[:] = False
        return normals[np.argmin(np.where(uphill, np.inf, margins))]

    def _exit_distance(self, point: np.ndarray, direction: np.ndarray) -> float:
        """Distance (m) from `point` along `direction` (unit) to the target rectangle's edge."""
        bounds = [(self.centre[a] + np.sign(direction[a]) * self.half[a] - point[a]) / direction[a]
                  for a in range(2) if abs(direction[a]) > 1e-9]
        return max(0.0, min(bounds))

    def _plan_withdraw(self) -> None:
        """The grasper withdraws to its trocar, jaws open; the retractor keeps pressing the laid
        loops (it is clear of the target), or withdraws too when the time is up."""
        g, r = "grasper", "retractor"
        up = dict(self.command[g], depth=0.0, jaw=JAW_OPEN_DEG)  # open: a success leaves the jaws open
        keep = self.press and self.pressing is not None and self.time + self.cycle_duration <= self.withdraw_at
        retractor = self._hold(r) if keep else self._move(r, dict(self.command[r], depth=0.0), 1.2)
        self.phases.append(_phase("withdraw", 1.5, self._move(g, up, 1.2), retractor))
        self.done = True

    def _over_covered_cells(self, points: np.ndarray, coverage: np.ndarray) -> np.ndarray:
        """Axis points whose tube lies over a covered cell of the target grid (as the reward sees it)."""
        cells = self.cells[np.asarray(coverage) > 0.5]
        if not len(cells):
            return np.zeros(len(points), dtype=bool)
        squared = ((points[:, None, :2] - cells[None, :, :]) ** 2).sum(axis=-1)
        return squared.min(axis=1) <= (1.5 * self.radius) ** 2

    def __call__(self, time_step) -> np.ndarray:
        if time_step.first():
            self._reset()
            self.command.update(self.tools.commands(time_step.observation))  # from where the tools start
            self.target(np.concatenate([time_step.observation["target"], time_step.observation["gravity"]]))
        axis = np.asarray(time_step.observation["intestine_axis"]).reshape(-1, 3)
        self.observation = time_step.observation
        while not self.phases or self.phase_time >= self.phases[0].duration:
            if self.phases:
                self.phase_time -= self.phases.pop(0).duration
            if not self.phases:
                coverage = time_step.observation["target_coverage"]
                if self.done and (self._stay(time_step.observation)
                                  or self.time + self.cycle_duration > self.withdraw_at):
                    # rest withdrawn, looking again every half second
                    self.phases.append(_phase("rest", 0.5, self._hold("grasper"), self._hold("retractor")))
                else:  # loops came back over the target: another cycle
                    self.done = False
                    self._plan(axis, coverage)
            # a move the velocity limits stretched finishes before the next phase starts from its goal
            first = self.phases[0]
            first.duration = max(first.duration, first.moves["grasper"].duration, first.moves["retractor"].duration)
        moves = self.phases[0].moves
        action = self.tools.action({"grasper": moves["grasper"](self.phase_time),
                                    "retractor": moves["retractor"](self.phase_time)})
        self.phase_time += self.control_timestep
        self.time += self.control_timestep
        return action

    def _stay(self, observation) -> bool:
        """Withdrawn, whether to stay so: enough of the target is still uncovered."""
        return 1.0 - float(np.mean(np.asarray(observation["target_coverage"]) > 0.5)) >= self.resume_below

    @property
    def phase(self) -> str:
        return self.phases[0].name if self.phases else "-"


class RetractReachGesture(ClearingGesture):
    """Policy for retract_reach: the clearing gesture on the working spot (the target's sampling
    points within `spot` m of its centre: by default the four around it), each loop over it
    carried where the taut-rope prediction leaves the spot clear and laid, the retractor pressing
    the laid loop down; once the spot is clear, the retractor (unless it presses already) holds
    down the loop nearest the centre outside the spot, and the grasper comes down on the
    target's centre, jaws open (closing jaws would take hold of a loop on the way), and stays
    while the centre is uncovered, the retractor presses and the grasper pushes on nothing
    (`target_coverage`, `tool_forces`); else it clears the spot again, and if the grasper pushed
    on a loop, the retractor first holds down the loop nearest its shaft (reaching again the
    same way pushed on it again). Where the spot is clear from the start, the retractor holds
    the nearest loop at once: waiting for it to press something, the reach never came."""

    def __init__(self, env, spot: float = 0.004, centre_radius: float = 0.004, press_force: float = 0.05,
                 push_force: float = 0.5, reach_height: float = 0.002, retract_gap: float = 0.015, **kwargs):
        self.spot = spot  # m
        self.centre_radius = centre_radius  # m: the coverage cells that make the target's centre
        self.press_force = press_force  # N: the retractor presses when its sensor reads this
        self.push_force = push_force  # N: the grasper pushes its way through loops above this
        self.reach_height = reach_height  # m: the tip's goal above the wall at the target's centre
        self.retract_gap = retract_gap  # m beyond the spot where the retractor holds the nearest loop
        kwargs = dict(dict(good_enough=1.0, resume_below=0.0, press=True, carry_height=0.07), **kwargs)
        super().__init__(env, **kwargs)

    def target(self, observation: np.ndarray) -> None:
        super().target(observation)
        distance = norms(self.cells - self.centre)
        self.in_spot = distance <= self.spot
        self.at_centre = distance <= self.centre_radius
        self.scored = self.in_spot
        self.half = np.array([self.spot, self.spot])  # loops leave the spot, not the whole target

    def _plan(self, axis: np.ndarray, coverage: np.ndarray) -> None:
        super()._plan(axis, np.where(self.in_spot, coverage, 0.0))

    def _retract(self, axis: np.ndarray, path: bool = False) -> None:
        """The retractor presses down the loop nearest the target's centre outside the spot (the
        one that would roll onto it), or with `path` the one nearest the grasper's shaft as it
        reaches the centre (the one it pushed on), on its top, its paddle along the bowel."""
        distance = norms(axis[:, :2] - self.centre)
        outside = np.flatnonzero(distance > self.spot + self.retract_gap)
        if not len(outside):
            return
        nearness = distance
        if path:  # nearest the grasper's shaft, its lowest 6 cm at the centre
            tip = np.append(self.centre, self.wall_z + self.reach_height)
            shaft = self.tools.trocar["grasper"] - tip
            shaft /= norm(shaft)
            along = np.clip(dot(axis - tip, shaft), 0.0, 0.06)
            nearness = norms(axis - (tip + along[:, None] * shaft))
        index = int(outside[np.argmin(nearness[outside])])
        tangent = axis[min(index + 1, len(axis) - 1), :2] - axis[max(index - 1, 0), :2]
        roll = math.degrees(math.atan2(float(tangent[1]), float(tangent[0])))
        roll = (roll + 90.0) % 180.0 - 90.0  # the paddle is symmetric: the shorter turn
        self._press_at(axis[index, :2], axis[index, 2] + self.radius, roll)

    def _stay(self, observation) -> bool:
        """At the target's centre, stay while the spot there is uncovered and the retractor
        presses; else clear it again."""
        coverage = np.asarray(observation["target_coverage"])
        forces = np.asarray(observation["tool_forces"])  # grasper then retractor, force then torque
        return (not (coverage[self.at_centre] > 0.5).any() and norm(forces[6:9]) >= self.press_force
                and norm(forces[0:3]) <= self.push_force)

    def _plan_withdraw(self) -> None:
        g = "grasper"
        centre = np.append(self.centre, self.wall_z + self.reach_height)
        forces = np.asarray(self.observation["tool_forces"])
        axis = np.asarray(self.observation["intestine_axis"]).reshape(-1, 3)
        if norm(forces[0:3]) > self.push_force:  # it pushed on a loop by its shaft: hold that one
            self._retract(axis, path=True)
        elif norm(forces[6:9]) < self.press_force:
            self._retract(axis)
        self.phases += [
            _phase("rise", 0.5, self._move(g, dict(self.command[g], depth=max(0.0, self.command[g]["depth"] - 0.04),
                                                  jaw=JAW_OPEN_DEG), 0.45), self._hold("retractor")),
            _phase("reach over", 0.8, self._move(g, self.coordinates(g, centre + (0, 0, 0.05), JAW_OPEN_DEG), 0.7),
                  self._hold("retractor")),
            _phase("reach", 0.8, self._move(g, self.coordinates(g, centre, JAW_OPEN_DEG), 0.7),
                  self._hold("retractor"))]
        self.done = True
