"""retract_reach: hold the loops off the target with the retractor while the grasper reaches it.

Bimanual exposure, the purpose of clearing: one tool holds the bowel back while the other works
on what it uncovered. Tools: the grasper (right trocar) and the retractor (left trocar).

- Episode: a settled start, tissue and tilt drawn per seed (viscera.tasks.base); the target (a
  6 x 5 cm patch of the posterior wall) placed where the settled bowel covers at least 60 % of it.
- Actions: the tools' position actuators, in their control ranges (rad, m).
- Observations: tool_joints, tool_forces, grasper_holding, intestine_axis, gravity, target
  (centre m (3), half sizes m (2)), target_coverage (10 x 10 grid), grasper_tip (m).
- Reward: 0.5 x the uncovered fraction + 0.5 x exp(-tip distance to the target centre / 2 cm).
- Success: for 0.5 s, the grasper's tip within 1 cm of the target's centre, the retractor
  pressing on the bowel (its force sensor reads at least 0.05 N) and at least 60 % of the target
  uncovered. The episode ends on success, or after 20 s.
"""

from __future__ import annotations

import numpy as np
from dm_control.rl import control

from viscera.tasks import base
from viscera.tasks.scene import Tool

REACH_M = 0.01        # tip to the target's centre
PRESS_N = 0.05        # the retractor's force sensor
UNCOVERED = 0.6
Physics = base.Physics


class RetractReach(base.BowelTask):
    """Retractor holds the loops off, grasper touches the target's centre for 0.5 s."""

    TOOLS = (Tool("grasper", "grasper", "right"), Tool("retractor", "retractor", "left"))
    HOLD_S = 0.5
    TIME_LIMIT_S = 20.0

    def draw(self, physics: Physics) -> None:
        if self.randomize:
            self.move_target(physics)

    def tip_distance(self, physics: Physics) -> float:
        return float(np.linalg.norm(physics.working_point("grasper") - physics.target()[:3]))

    def condition(self, physics: Physics) -> bool:
        return (self.tip_distance(physics) <= REACH_M and
                np.linalg.norm(physics.named.data.sensordata["retractor_force"][:3]) >= PRESS_N and
                physics.uncovered_fraction() >= UNCOVERED)

    def task_observations(self, physics: Physics) -> dict:
        return {"target": physics.target(), "target_coverage": physics.coverage(),
                "grasper_tip": physics.working_point("grasper")}

    def get_reward(self, physics: Physics) -> float:
        return 0.5 * physics.uncovered_fraction() + 0.5 * float(np.exp(-self.tip_distance(physics) / 0.02))


def load(seed: int | None = None, time_limit: float | None = None, control_timestep: float = 0.02,
         axis_samples: int = base.AXIS_SAMPLES, randomize: bool = True) -> control.Environment:
    """The retract_reach environment (time limit, default 20, and control period in s)."""
    task = RetractReach(random=np.random.RandomState(seed), axis_samples=base.checked_axis_samples(axis_samples),
                        randomize=randomize)
    return base.make(task, time_limit, control_timestep)


def scripted_policy(env):
    """Sweep with the retractor, then reach (viscera.tasks.policies.RetractReachPolicy)."""
    from viscera.tasks.policies import RetractReachPolicy
    return RetractReachPolicy(env)
