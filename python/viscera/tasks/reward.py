"""The reward contract every bowel task pays by: success is the return's optimum.

Every task ends on success, so a per-step reward in [0, 1] (what dm_control's suite pays over a
fixed-length episode) makes never succeeding the best return: an agent that hovers just short of
the goal for the whole episode earns more than one that succeeds. The tasks therefore pay their
dense shaping as the change of a potential (Ng, Harada and Russell, "Policy invariance under
reward transformations", ICML 1999), which sums over any episode to its last state's potential
less its first, whatever happens in between, plus a time cost and a success bonus.

With Phi(s) in [0, 1] the task's potential (its progress towards the goal), c the time cost of a
control step and S the success bonus, the reward of the step to s_k (k = 1, 2, ...) is
- Phi(s_k) - Phi(s_k-1) - c                   while the episode goes on;
- 1 - Phi(s_k-1) - c + S                      on the step success first holds (Phi counts as 1 there);
- Phi(s_k) - Phi(s_k-1) - c - c (N - k)       on a failure that ends the episode at step k of N:
                                              it is charged the time cost of the steps it skipped.
So an episode's return is exactly
- 1 - Phi(s_0) + S - c k                      for a success at step k;
- Phi(s_N) - Phi(s_0) - c N <= 1 - Phi(s_0) - c N   for an episode without success, N steps long
                                              (truncated at the time limit, or failed and charged to it).
A success at step k therefore beats a success at any later step (by c per step) and every episode
without success (by at least S + c (N - k) > 0), whatever the agent did before: `Contract` states
the bounds and proves both from them, and tests/python/test_rewards.py checks each task's episodes
against them and runs adversaries (hovering, dropping, stirring) against the scripted policy.

c is 1 / (the task's default episode length in control steps): the time cost of a whole default
episode is 1, the potential's range. S is 1.

`reward="sparse"` pays 1 on the step success first holds and 0 otherwise, as LapGym
(sofa_env's reward "sparse" modes) and robosuite (reward_shaping=False) offer: a learner's own
discount then prefers sooner success.
"""

from __future__ import annotations

import dataclasses
import math

KINDS = ("dense", "sparse")
DEFAULT_KIND = "dense"
SUCCESS_BONUS = 1.0
POTENTIAL_RANGE = (0.0, 1.0)


def checked_kind(kind) -> str:
    if not isinstance(kind, str) or kind not in KINDS:
        raise ValueError(f"reward = {kind!r}: must be one of {', '.join(repr(k) for k in KINDS)}")
    return kind


def step_limit(time_limit_s: float, control_timestep_s: float) -> float:
    """The number of control steps an episode lasts at most, as dm_control counts them (it ends
    once its step count reaches time_limit / control_timestep); inf for an unlimited episode."""
    if math.isinf(time_limit_s):
        return math.inf
    return float(math.ceil(time_limit_s / control_timestep_s))


@dataclasses.dataclass(frozen=True)
class Contract:
    """One task's dense reward: its potential's range, the time cost per control step, the success
    bonus and the episode's length in control steps (see the module doc)."""

    time_cost: float                          # c, per control step
    steps: float                              # N, the step limit (inf: none)
    success_bonus: float = SUCCESS_BONUS      # S
    potential: tuple[float, float] = POTENTIAL_RANGE  # Phi's bounds

    @classmethod
    def of(cls, default_time_limit_s: float, time_limit_s: float, control_timestep_s: float) -> "Contract":
        """The contract of a task whose default episode lasts `default_time_limit_s` s, loaded with
        `time_limit_s` s and `control_timestep_s` s steps."""
        return cls(time_cost=control_timestep_s / default_time_limit_s,
                   steps=step_limit(time_limit_s, control_timestep_s))

    # -- each step's reward (the module doc's three cases)
    def step(self, potential_before: float, potential: float) -> float:
        return potential - potential_before - self.time_cost

    def success(self, potential_before: float) -> float:
        return self.potential[1] - potential_before - self.time_cost + self.success_bonus

    def failure(self, potential_before: float, potential: float, step: int) -> float:
        """A failure at control step `step` (1-based): charged the time cost of the steps it skipped
        (with no step limit, the potential's range and the bonus, so that it still ranks below any
        success at the same step)."""
        skipped = (self.steps - step) * self.time_cost if math.isfinite(self.steps) else \
            (self.potential[1] - self.potential[0]) + self.success_bonus
        return self.step(potential_before, potential) - max(0.0, skipped)

    # -- each step's bounds
    def step_bounds(self) -> tuple[float, float]:
        """The reward of a step that neither succeeds nor fails."""
        low, high = self.potential
        return low - high - self.time_cost, high - low - self.time_cost

    def success_bounds(self) -> tuple[float, float]:
        low, high = self.potential
        return self.success_bonus - self.time_cost, high - low + self.success_bonus - self.time_cost

    # -- the returns they sum to (potential_start: Phi(s_0))
    def success_return(self, step: int, potential_start: float) -> float:
        """The return of an episode that succeeds at control step `step` (exact: the potential's
        changes telescope)."""
        return self.potential[1] - potential_start + self.success_bonus - self.time_cost * step

    def best_return_without_success(self, potential_start: float) -> float:
        """The most an episode without success returns (it lasts, or is charged, all N steps)."""
        return self.potential[1] - potential_start - self.time_cost * self.steps

    def proof(self) -> list[str]:
        """Check, from the bounds alone, that a success beats every later success and every episode
        without one, at every step of the episode and from any start; the violations (none when
        the contract holds)."""
        problems = []
        if not self.time_cost > 0.0:
            problems.append(f"time cost {self.time_cost}: a later success would return as much as a sooner one")
        if not math.isfinite(self.steps):
            problems.append("no step limit: an unlimited episode without success has no least return")
            return problems
        for start in self.potential:
            worst_success = self.success_return(int(self.steps), start)  # the latest possible success
            if not worst_success > self.best_return_without_success(start):
                problems.append(f"from potential {start}: a success at the last step returns {worst_success}, "
                                f"not more than {self.best_return_without_success(start)} without success")
        return problems
