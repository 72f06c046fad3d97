"""grasp_lift: grasp a marked band of bowel and hold it up, off the posterior wall.

The first move of most bowel manipulation: take hold of the loop the surgeon wants (here a
5 cm band, drawn blue by MuJoCo's renderer) and lift it clear. Tools: the grasper (right trocar).

- Episode: a settled start, tissue and tilt drawn per seed (viscera.tasks.base); the band's
  centre drawn at a random abscissa (0.3 to 2.7 m of the 3 m): of eight draws, the most exposed
  (highest) within the grasper's reach (its shaft within 55 degrees of vertical), so that it is
  neither buried under the whole pile nor in a corner the port cannot serve.
- Actions: the grasper's position actuators, in their control ranges (rad, m).
- Observations: tool_joints, tool_forces, grasper_holding, intestine_axis, gravity, band (the
  band's 5 axis points, m, (5, 3) flattened, from one end to the other), held_abscissa (the held
  point, m along the rest axis; -1 when not holding), band_abscissa (its from and to, m).
- Reward (viscera.tasks.reward): the change of the potential, a time cost, a bonus on success.
  The potential: 1 while the condition holds, else 0.5 for the tip's nearness to the band
  (exp(-distance / 5 cm)) plus 0.5 x the held band's height over 5 cm while holding it.
- Success: the grasper holds a point of the band (within 1 cm of it) at least 5 cm above the
  posterior wall, for 1 s without slipping (a slip lets go: the clock starts again). The episode
  ends on success, or after 15 s.
- Scripted policy: viscera.tasks.policies.GraspLiftPolicy, closed loop from the observations.
"""

from __future__ import annotations

import math

import numpy as np

import viscera

from viscera.tasks import base
from viscera.tasks.base import Physics
from viscera.tasks.policies import GraspLiftPolicy
from viscera.tasks.scene import Tool

BAND_M = 0.05         # the band's length along the axis
LIFT_M = 0.05         # above the posterior wall
SLACK_M = 0.01        # a hold this close to the band counts
BAND_POINTS = 5


@base.register("grasp_lift", "viscera/GraspLift-v0")
class GraspLift(base.BowelTask):
    """Hold the marked band at least 5 cm up for 1 s."""

    CRITERION = "the marked band held 5 cm above the posterior wall for 1 s"
    TOOLS = (Tool("grasper", "grasper", "right"),)
    HOLD_S = 1.0
    HAS_TARGET = False
    TIME_LIMIT_S = 15.0
    POLICY = GraspLiftPolicy

    def __init__(self, random=None, axis_samples: int = base.AXIS_SAMPLES, randomize: bool = True,
                 scene: str = base.scene.DEFAULT_SCENE):
        super().__init__(random=random, axis_samples=axis_samples, randomize=randomize, scene=scene)
        self.band = (1.5 - BAND_M / 2, 1.5 + BAND_M / 2)  # m along the rest axis: drawn per episode

    def intestine_config(self) -> dict[str, str]:
        return {"marked_band": viscera.fixed_width_numbers(self.band)}  # rewritten in place each episode

    def draw(self, physics: Physics) -> None:
        length = physics.intestine().rest_length
        centres = self.random.uniform(0.1 * length, 0.9 * length, 8)
        points = [physics.axis_point_at(centre) for centre in centres]
        reach = [base.within_reach(physics, "grasper", point) for point in points]
        heights = [point[2] if ok else point[2] - 1.0 for point, ok in zip(points, reach)]  # reachable first
        centre = float(centres[int(np.argmax(heights))])
        self.band = (centre - BAND_M / 2, centre + BAND_M / 2)

    def view_point(self, physics: Physics) -> np.ndarray:
        return physics.axis_point_at(0.5 * (self.band[0] + self.band[1]))

    def band_points(self, physics: Physics) -> np.ndarray:
        """The band's BAND_POINTS axis points (m, (5, 3)), from one end to the other."""
        return self.measurements(physics).memo(
            "band_points", lambda: physics.axis_points_at(np.linspace(*self.band, BAND_POINTS)))

    def held_band_height(self, physics: Physics) -> float | None:
        """Height (m) above the posterior wall of the held point if a grasper holds the band, else None."""
        def measure():
            for grasp in physics.intestine().grasps(physics.data.ptr):
                if grasp.holding and self.band[0] - SLACK_M <= grasp.abscissa <= self.band[1] + SLACK_M:
                    return float(physics.axis_point_at(grasp.abscissa)[2])
            return None
        return self.measurements(physics).memo("held_band_height", measure)

    def condition(self, physics: Physics) -> bool:
        height = self.held_band_height(physics)
        return height is not None and height >= LIFT_M

    def task_observations(self, physics: Physics) -> dict:
        return {"band": self.band_points(physics).ravel(), "held_abscissa": physics.held_abscissae(),
                "band_abscissa": np.array(self.band)}

    def potential(self, physics: Physics) -> float:
        if self.condition(physics):
            return 1.0
        offsets = self.band_points(physics) - physics.working_point("grasper")
        near = math.exp(-math.sqrt(float((offsets * offsets).sum(axis=1).min())) / 0.05)
        height = self.held_band_height(physics)
        return 0.5 * near + (0.5 * min(1.0, max(0.0, height) / LIFT_M) if height is not None else 0.0)


load = base.loader(GraspLift)
