"""A rollout worker: holds task environments, steps them under a policy, returns trajectories.

The same RolloutWorker runs in every backend of viscera.scale: in the calling
thread, in a thread, in a worker process and as a Ray actor. It keeps its
environments between calls (loading the scene costs more than an episode's
first steps), one per seed of the largest batch it has been given, and steps
its batch in lockstep, as a learner's actor does (a batched policy would be
evaluated once per step for the whole batch).

A trajectory is one episode from reset, cut after `steps` actions or at the
episode's end, whichever comes first. Its seed seeds the task's RandomState and
the policy (clear_area draws nothing at reset, so there only the policy differs). It depends only on (task, task kwargs,
policy, seed, steps): not on the backend, the worker it ran on or the other
seeds of its batch (tested bit for bit).
"""

from __future__ import annotations

import dataclasses

import numpy as np

import viscera.tasks
from viscera.scale import observations
from viscera.checks import checked_integer, finite_array

SEED_LIMIT = 2 ** 32  # numpy's RandomState, which dm_control tasks draw from, takes seeds below this


def checked_seeds(seeds) -> list[int]:
    """The seeds as ints, each refused by position unless an integer in [0, 2**32), none repeated."""
    seeds = list(seeds)
    for i, seed in enumerate(seeds):
        if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or not 0 <= seed < SEED_LIMIT:
            raise ValueError(f"seeds[{i}] = {seed!r}: must be an integer in [0, 2**32)")
    seeds = [int(s) for s in seeds]
    if len(set(seeds)) != len(seeds):
        raise ValueError(f"seeds repeat: {sorted(s for s in set(seeds) if seeds.count(s) > 1)}")
    return seeds


@dataclasses.dataclass(eq=False)
class Trajectory:
    """One episode's record; unpacks as (observations, actions, rewards)."""

    seed: int
    observations: np.ndarray   # (T + 1, D) float64 (or float32 if asked): the reset observation, then one per action
    actions: np.ndarray        # (T, nu): the actions taken (the tools' actuator controls)
    rewards: np.ndarray        # (T,): the task's reward after each action
    discounts: np.ndarray      # (T,): dm_env discounts (0 where the task ended the episode)
    observation_layout: dict   # key -> (slice of the D entries, shape), see viscera.scale.observations
    ended: bool = False        # the episode ended (time limit or task) within the trajectory

    def __iter__(self):
        return iter((self.observations, self.actions, self.rewards))

    @property
    def steps(self) -> int:
        return len(self.actions)

    def observation(self, key: str) -> np.ndarray:
        """One observation entry over the trajectory, (T + 1, *shape)."""
        return observations.unflatten(self.observations, self.observation_layout)[key]

    def same_as(self, other: "Trajectory") -> bool:
        """Bit-identical records of the same seed."""
        return (self.seed == other.seed and self.ended == other.ended
                and all(np.array_equal(a, b) for a, b in zip(self.arrays(), other.arrays())))

    def arrays(self) -> tuple[np.ndarray, ...]:
        return self.observations, self.actions, self.rewards, self.discounts

    @property
    def nbytes(self) -> int:
        return sum(a.nbytes for a in self.arrays())


class RandomPolicy:
    """Smooth random tool motion for exploration.

    Controls move linearly between knots drawn uniformly within the action bounds
    every `knot_interval` s, starting from the controls at reset, so the tools
    sweep the cavity, press on and pull the bowel, and open and close the jaws.
    Deterministic in its seed.
    """

    def __init__(self, env, seed: int, knot_interval: float = 0.5):
        spec = env.action_spec()
        self.low, self.high = np.broadcast_to(spec.minimum, spec.shape), np.broadcast_to(spec.maximum, spec.shape)
        self.knot_steps = max(1, int(round(knot_interval / env.control_timestep())))
        self.rng = np.random.default_rng(seed)
        self.physics = env.physics
        self.step = 0
        self.knots = None

    def __call__(self, time_step) -> np.ndarray:
        if time_step.first():
            self.step = 0
            start = np.clip(self.physics.data.ctrl, self.low, self.high)
            self.knots = (start, self.rng.uniform(self.low, self.high))
        within = self.step % self.knot_steps
        if within == 0 and self.step > 0:
            self.knots = (self.knots[1], self.rng.uniform(self.low, self.high))
        self.step += 1
        fraction = (within + 1) / self.knot_steps
        return (1.0 - fraction) * self.knots[0] + fraction * self.knots[1]


def random_policy(env, seed: int):
    return RandomPolicy(env, seed)


def scripted_policy(env, seed: int):
    """The task's scripted policy (viscera.tasks.scripted_policy); it does not use the seed."""
    return viscera.tasks.scripted_policy(env)


# "gesture", the clearing gesture's old name here, is clear_area's scripted policy
POLICIES = {"random": random_policy, "scripted": scripted_policy, "gesture": scripted_policy}
OBSERVATION_DTYPES = ("float64", "float32")


def policy_factory(policy):
    """A `make(env, seed) -> policy` from a name in POLICIES or such a callable."""
    if isinstance(policy, str):
        if policy not in POLICIES:
            raise ValueError(f"policy = {policy!r}: must be one of {tuple(POLICIES)} or a callable(env, seed)")
        return POLICIES[policy]
    if not callable(policy):
        raise ValueError(f"policy = {policy!r}: must be one of {tuple(POLICIES)} or a callable(env, seed)")
    return policy


class RolloutWorker:
    """Environments of one task and a policy per seed (see the module doc).

    task: a name in viscera.tasks.ALL; task_kwargs: passed to viscera.tasks.load
    (time_limit, control_timestep, axis_samples, ...); policy: a name in POLICIES or a
    picklable callable (env, seed) -> policy, a policy mapping a dm_env TimeStep to an
    action; observation_dtype: "float64" (exact) or "float32" (half the bytes to ship;
    the policy still sees the float64 observation).
    """

    def __init__(self, task: str = "clear_area", policy="random", task_kwargs: dict | None = None,
                 observation_dtype: str = "float64"):
        if task not in viscera.tasks.ALL:
            raise ValueError(f"task = {task!r}: must be one of {viscera.tasks.ALL}")
        if observation_dtype not in OBSERVATION_DTYPES:
            raise ValueError(f"observation_dtype = {observation_dtype!r}: must be one of {OBSERVATION_DTYPES}")
        self.task = task
        self.task_kwargs = dict(task_kwargs or {})
        self.make_policy = policy_factory(policy)
        self.observation_dtype = np.dtype(observation_dtype)
        self.envs = []

    def _environments(self, count: int) -> list:
        while len(self.envs) < count:
            self.envs.append(viscera.tasks.load(self.task, seed=None, **self.task_kwargs))
        return self.envs[:count]

    def ready(self) -> bool:
        """True: lets a caller wait until a remote worker has been constructed."""
        return True

    def run(self, seeds, steps: int) -> list[Trajectory]:
        """One trajectory per seed, in the order given (see the module doc)."""
        seeds = checked_seeds(seeds)
        steps = checked_integer("steps", steps, 0)
        envs = self._environments(len(seeds))
        places, time_steps, policies, records = None, [], [], []
        for env, seed in zip(envs, seeds):
            viscera.tasks.reseed(env, seed)
            time_step = env.reset()
            places = places or observations.layout(env.observation_spec())
            nu = env.action_spec().shape[0]
            policies.append(self.make_policy(env, seed))
            time_steps.append(time_step)
            records.append({"observations": np.empty((steps + 1, observations.size(places)), self.observation_dtype),
                            "actions": np.empty((steps, nu)), "rewards": np.empty(steps),
                            "discounts": np.empty(steps), "length": 0})
            records[-1]["observations"][0] = observations.flatten(time_step.observation, places)
        for t in range(steps):  # lockstep over the batch; an ended episode stops recording
            for env, policy, record, i in zip(envs, policies, records, range(len(envs))):
                if time_steps[i].last():
                    continue
                # a policy's NaN or wrong-sized action stops here, named, before it reaches MuJoCo
                action = finite_array(f"action of the policy for seed {seeds[i]} at step {t}",
                                      policy(time_steps[i]), (nu,))
                time_steps[i] = time_step = env.step(action)
                record["actions"][t] = action
                record["rewards"][t] = time_step.reward
                record["discounts"][t] = time_step.discount
                record["observations"][t + 1] = observations.flatten(time_step.observation, places)
                record["length"] = t + 1
        trajectories = []
        for seed, record, time_step in zip(seeds, records, time_steps):
            n = record["length"]  # below steps when the episode ended first
            trajectories.append(Trajectory(
                seed=seed, observations=record["observations"][:n + 1], actions=record["actions"][:n],
                rewards=record["rewards"][:n], discounts=record["discounts"][:n],
                observation_layout=places, ended=bool(n) and time_step.last()))
        return trajectories
