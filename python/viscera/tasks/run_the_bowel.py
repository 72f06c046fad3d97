"""run_the_bowel: inspect the small bowel hand over hand with two graspers.

How surgeons inspect the small bowel ("running the bowel"): two atraumatic graspers advance
along it alternately, always holding it with at least one jaw, until the stretch of interest has
passed between them. Tools: two graspers, `grasper` (right trocar) and `grasper_left` (left
trocar, in place of the retractor).

- Episode: a settled start, tissue and tilt drawn per seed (viscera.tasks.base); the start mark,
  a 3 cm band (drawn blue) at a random abscissa 0.5 to 2.5 m along the 3 m: of eight draws, the
  most exposed (highest) that both graspers reach.
- Actions: both graspers' position actuators, in their control ranges (rad, m).
- Observations: tool_joints, tool_forces, grasper_holding (per grasper), intestine_axis, gravity,
  start_mark (its axis point, m (3), then its abscissa, m), intestine_length (m), held_abscissa
  (per grasper: m along the rest axis, -1 when not holding), advance (m: the farthest held point
  from the mark since the run began), counted_abscissa (per grasper: its hold as the run counts it,
  m along the rest axis; -1 when it holds nothing or a hold that does not count).
- Reward (viscera.tasks.reward): the change of the potential, a time cost, a bonus on success
  and a charge on a drop. The potential: before the run begins, 0.1 x the nearest grasper tip's
  nearness to the mark (exp(-distance / 5 cm)); once it has begun, 0.1 + 0.9 x the advance over
  30 cm (at most 1).
- Run: it begins when a jaw takes the bowel within 3 cm of the mark. A later hold counts when it
  takes the bowel within 10 cm (along it) of a hold that counts: hand over hand; a jaw closing on
  another loop does not count. From the start on, at least one counted hold at every step, or the
  run is dropped and the episode ends (discount 0).
- Success: at least 30 cm of bowel has passed between the jaws (the advance: the farthest counted
  hold from the mark) with the bowel held throughout. The episode ends on success, a drop, or after 40 s.
- Scripted policy: viscera.tasks.policies.RunTheBowelPolicy, hand over hand from the observations.
"""

from __future__ import annotations

import math

import numpy as np

import viscera

from viscera.tasks import base
from viscera.tasks.base import Physics
from viscera.tasks.policies import RunTheBowelPolicy
from viscera.tasks.scene import Tool

MARK_M = 0.03        # the start mark's length along the axis
START_SLACK_M = 0.03  # a first hold this close to the mark begins the run
ADVANCE_M = 0.30
HANDOVER_M = 0.10    # a new hold counts within this of a counted one (the jaws hand over, they do not jump)


@base.register("run_the_bowel", "viscera/RunTheBowel-v0")
class RunTheBowel(base.BowelTask):
    """Advance 30 cm along the bowel, hand over hand, never letting go."""

    CRITERION = "30 cm of bowel run hand over hand without letting go"
    TOOLS = (Tool("grasper", "grasper", "right"), Tool("grasper_left", "grasper", "left"))
    HAS_TARGET = False
    TIME_LIMIT_S = 40.0
    POLICY = RunTheBowelPolicy

    def __init__(self, random=None, axis_samples: int = base.AXIS_SAMPLES, randomize: bool = True,
                 scene: str = base.scene.DEFAULT_SCENE):
        super().__init__(random=random, axis_samples=axis_samples, randomize=randomize, scene=scene)
        self.mark = 1.5  # m along the rest axis: drawn per episode
        self._reset_run()

    def _reset_run(self) -> None:
        self.started = False
        self.dropped = False
        self.advance = 0.0
        self.counted: list[float | None] = [None] * len(self.TOOLS)  # per jaw: its counted hold (m)

    def intestine_config(self) -> dict[str, str]:
        return {"marked_band": viscera.fixed_width_numbers((self.mark - MARK_M / 2, self.mark + MARK_M / 2))}

    def initialize_episode(self, physics: Physics) -> None:
        self._reset_run()
        super().initialize_episode(physics)

    def view_point(self, physics: Physics) -> np.ndarray:
        return physics.axis_point_at(self.mark)

    def draw(self, physics: Physics) -> None:
        """The mark: of eight draws, the most exposed (highest) that both graspers reach."""
        marks = self.random.uniform(0.5, 2.5, 8)
        points = [physics.axis_point_at(mark) for mark in marks]
        reachable = [all(base.within_reach(physics, tool.name, point) for tool in self.TOOLS) for point in points]
        heights = [point[2] if ok else point[2] - 1.0 for point, ok in zip(points, reachable)]  # reachable first
        self.mark = float(marks[int(np.argmax(heights))])

    def after_step(self, physics: Physics) -> None:
        """Follow the run: a jaw's hold counts when it is the first, within 3 cm of the mark, or
        when it takes the bowel within HANDOVER_M of a hold that counts (hand over hand, not a
        jump to another loop); the advance is the farthest counted hold from the mark."""
        for jaw, held in enumerate(physics.held_abscissae()):
            previous = self.counted[jaw]
            if held < 0.0:
                self.counted[jaw] = None
            elif previous is None or abs(held - previous) > 0.005:  # a new hold
                others = [s for j, s in enumerate(self.counted) if j != jaw and s is not None]
                near_mark = not self.started and abs(held - self.mark) <= START_SLACK_M
                self.counted[jaw] = held if near_mark or any(abs(held - s) <= HANDOVER_M for s in others) else None
        counted = [s for s in self.counted if s is not None]
        self.started = self.started or bool(counted)
        if self.started and not counted:
            self.dropped = True
        if counted and not self.dropped:
            self.advance = max(self.advance, max(abs(s - self.mark) for s in counted))
        super().after_step(physics)

    def condition(self, physics: Physics) -> bool:
        return self.started and not self.dropped and self.advance >= ADVANCE_M

    def failure(self, physics: Physics) -> bool:
        return self.dropped

    def mark_point(self, physics: Physics) -> np.ndarray:
        """The start mark's axis point (m)."""
        return self.measurements(physics).memo("mark_point", lambda: physics.axis_point_at(self.mark))

    def task_observations(self, physics: Physics) -> dict:
        return {"start_mark": np.append(self.mark_point(physics), self.mark),
                "intestine_length": np.array([physics.intestine().rest_length]),
                "held_abscissa": physics.held_abscissae(), "advance": np.array([self.advance]),
                "counted_abscissa": np.array([-1.0 if c is None else c for c in self.counted])}

    def potential(self, physics: Physics) -> float:
        if self.started:
            return 0.1 + 0.9 * min(1.0, self.advance / ADVANCE_M)
        mark = self.mark_point(physics)
        nearest = min(float(np.sqrt(((physics.working_point(tool.name) - mark) ** 2).sum())) for tool in self.TOOLS)
        return 0.1 * math.exp(-nearest / 0.05)


load = base.loader(RunTheBowel)
