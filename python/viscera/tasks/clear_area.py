"""clear_area: uncover a patch of the posterior wall, and leave it uncovered.

The surgical gesture of France et al. (2002): pull and fold the loops aside "so that they do not
come back to their previous position", to reach a target area. Tools: the grasper (right trocar)
and the retractor (left trocar).

- Episode: a settled start, tissue and tilt drawn per seed (viscera.tasks.base); the target (a
  4 x 3 cm patch of the posterior wall; the shipped scene's is 6 x 5) placed where the settled
  bowel covers at least 60 % of it (of 16 draws, the one under the fewest loops).
- Actions: the tools' position actuators, in their control ranges (rad, m).
- Observations: tool_joints, tool_command (the last actuator targets, rad, m), tool_forces (N,
  the force the intestine exerts on each tool), grasper_holding, intestine_axis (axis_samples
  points, m), gravity, target (centre m (3), half sizes m (2)), target_coverage (10 x 10 grid: 1
  where the tube lies over the point), held_abscissa (m along the bowel where the grasper holds
  it, -1 when it holds nothing).
- Reward (viscera.tasks.reward): the change of the potential, a time cost, a bonus on success.
  The potential: 1 while the condition holds, else 0.8 x the uncovered fraction over 80 % (at
  most 1) plus 0.2 x the share of the other three conditions that hold (jaws open, tools clear,
  tools still) once the target is 80 % uncovered.
- Success (`success(physics)`): for the last 2 s of simulated time, at least 80 % of the target
  uncovered, the grasper's jaws open and holding nothing, both tools clear of the target (outside
  it grown by 1 cm, or 5 cm above the wall) and still (every tool joint under 0.3 rad/s or
  0.03 m/s): the loops stay where they were put, not while tools keep stirring them. The episode ends on success, or after 90 s.
- Scripted policy: the clearing gesture (viscera.tasks.gesture.ClearingGesture), an oracle that
  decides every step from the observation (viscera.tasks.oracle). How often it succeeds is
  measured in docs/tasks/rates.json (python python/tools/task_rates.py).
"""

from __future__ import annotations

from viscera.tasks import base
from viscera.tasks.base import Physics
from viscera.tasks.gesture import ClearingGesture
from viscera.tasks.scene import Tool

UNCOVERED = 0.8    # fraction of the target


@base.register("clear_area", "viscera/ClearArea-v0")
class ClearArea(base.BowelTask):
    """Uncover the target area and leave it so; reward is the uncovered fraction."""

    CRITERION = "the target uncovered for 2 s, the tools clear of it and still"
    TOOLS = (Tool("grasper", "grasper", "right"), Tool("retractor", "retractor", "left"))
    HOLD_S = 2.0
    TIME_LIMIT_S = 90.0
    POLICY = ClearingGesture

    def __init__(self, random=None, end_on_success: bool = True, axis_samples: int = base.AXIS_SAMPLES,
                 randomize: bool = True, scene: str = base.scene.DEFAULT_SCENE):
        """end_on_success False: a lasting success does not end the episode (e.g. to watch a
        gesture finish)."""
        super().__init__(random=random, axis_samples=axis_samples, randomize=randomize, scene=scene)
        self.end_on_success = end_on_success

    def tools_done(self, physics: Physics) -> tuple[bool, bool, bool]:
        """The success's conditions on the tools: jaws open, tools clear of the target, tools still."""
        return self.measurements(physics).memo(
            "tools_done", lambda: (physics.jaws_open(), physics.tools_clear_of_target(), physics.tools_still()))

    def condition(self, physics: Physics) -> bool:
        return self.measurements(physics).uncovered_fraction >= UNCOVERED and all(self.tools_done(physics))

    def task_observations(self, physics: Physics) -> dict:
        return {"target": physics.target(), "target_coverage": self.measurements(physics).coverage.copy(),
                "held_abscissa": physics.held_abscissae()}

    def potential(self, physics: Physics) -> float:
        uncovered = self.measurements(physics).uncovered_fraction
        if uncovered < UNCOVERED:
            return 0.8 * uncovered / UNCOVERED
        done = self.tools_done(physics)
        return 1.0 if all(done) else 0.8 + 0.2 * sum(done) / 3.0

    def get_termination(self, physics: Physics):
        return super().get_termination(physics) if self.end_on_success else None


load = base.loader(ClearArea)
