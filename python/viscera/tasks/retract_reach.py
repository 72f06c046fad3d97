"""retract_reach: hold the loops off the target with the retractor while the grasper reaches it.

Bimanual exposure, the purpose of clearing: one tool holds the bowel back while the other works
on what it uncovered. Tools: the grasper (right trocar) and the retractor (left trocar).

- Episode: a settled start, tissue and tilt drawn per seed (viscera.tasks.base); the target (a
  4 x 3 cm patch of the posterior wall; the shipped scene's is 6 x 5) placed where the settled
  bowel covers at least 60 % of it (of 16 draws, the one under the fewest loops).
- Actions: the tools' position actuators, in their control ranges (rad, m).
- Observations: tool_joints, tool_command, tool_forces, grasper_holding, intestine_axis, gravity,
  target (centre m (3), half sizes m (2)), target_coverage (10 x 10 grid), held_abscissa (m
  along the bowel, -1 for none), grasper_tip (m).
- Reward (viscera.tasks.reward): the change of the potential, a time cost, a bonus on success.
  The potential: 1 while the condition holds, else 0.5 x the uncovered fraction + 0.5 x
  exp(-tip distance to the target centre / 2 cm).
- Success: for 0.5 s, the grasper's tip within 1 cm of the target's centre, the centre uncovered
  (no tube over it: every tube axis farther than its radius, horizontally, as the coverage grid
  counts), and the grasper pushing on the bowel with at most 0.5 N (it reaches the wall the
  retractor uncovered, it does not push its way through the loops; a loop resting against its
  shaft is allowed), while the retractor presses on the bowel (its force sensor reads at least
  0.05 N). The episode ends on success, or after 60 s.
- Scripted policy: viscera.tasks.gesture.RetractReachGesture, an oracle (viscera.tasks.oracle):
  the clearing gesture on the working spot while the retractor presses the loop nearest it, then
  the grasper reaches, giving way to a loop that presses on it.
"""

from __future__ import annotations

import math

import numpy as np

from viscera.numerics import norm
from viscera.tasks import base
from viscera.tasks.base import Physics
from viscera.tasks.gesture import RetractReachGesture
from viscera.tasks.scene import Tool

REACH_M = 0.01        # tip to the target's centre
PRESS_N = 0.05        # the retractor's force sensor: it presses on the bowel
PUSH_N = 0.5          # the grasper's: it reaches the exposed wall, it does not push through loops


@base.register("retract_reach", "viscera/RetractReach-v0")
class RetractReach(base.BowelTask):
    """Retractor holds the loops off, grasper touches the target's centre for 0.5 s."""

    CRITERION = "the loops held back and the grasper at the target's centre"
    TOOLS = (Tool("grasper", "grasper", "right"), Tool("retractor", "retractor", "left"))
    HOLD_S = 0.5
    TIME_LIMIT_S = 60.0
    POLICY = RetractReachGesture

    def tip_distance(self, physics: Physics) -> float:
        """The grasper's tip to the target's centre (m)."""
        def measure():
            offset = physics.working_point("grasper") - physics.target()[:3]
            return math.sqrt(float((offset * offset).sum()))
        return self.measurements(physics).memo("tip_distance", measure)

    def centre_uncovered(self, physics: Physics) -> bool:
        """No tube over the target's centre: every axis point farther than the tube's radius from
        it, horizontally (a loop lifted above it covers it too)."""
        axis = self.measurements(physics).dense_axis[:, :2]
        return float(np.min(np.linalg.norm(axis - physics.target()[:2], axis=1))) > physics.intestine().radius

    def condition(self, physics: Physics) -> bool:
        forces = physics.named.data.sensordata
        return (self.tip_distance(physics) <= REACH_M and
                norm(forces["retractor_force"][:3]) >= PRESS_N and
                norm(forces["grasper_force"][:3]) <= PUSH_N and self.centre_uncovered(physics))

    def task_observations(self, physics: Physics) -> dict:
        return {"target": physics.target(), "target_coverage": self.measurements(physics).coverage.copy(),
                "held_abscissa": physics.held_abscissae(),
                "grasper_tip": physics.working_point("grasper")}

    def potential(self, physics: Physics) -> float:
        if self.condition(physics):
            return 1.0
        uncovered = self.measurements(physics).uncovered_fraction
        return 0.5 * uncovered + 0.5 * math.exp(-self.tip_distance(physics) / 0.02)


load = base.loader(RetractReach)
