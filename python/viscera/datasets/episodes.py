"""One episode of a task under a demonstrator, in the arrays a dataset writes.

An Episode holds, per control tick, what gymnasium's TaskEnv shows a learner (the flat state
vector, the camera's images with pixels on, the normalised action, the reward, terminated and
truncated, is_success) and, apart and named, the privileged state no observation gives in full:
the intestine's control points, every tool's force on the tissue and the grasps. Observations
and privileged state have one row more than actions: the reset's.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from viscera.checks import finite_array
from viscera.scale.gym_env import IMAGE_KEYS, TaskEnv

DEMONSTRATORS = ("scripted", "random", "idle")   # with "recordings": the episodes of recording files; "policy": a policy file's
ORACLE_LABELS = {  # name -> what it is (units), per action of a scripted oracle
    "phase": "the oracle's phase: its index in the task's oracle's PHASES (viscera.tasks.oracle_phases)",
    "lead": "the tool the phase is about: its index in the task's tools (the actuators' order)",
    "aims": "where each tool's working point is going (m, world), tools in the actuators' order (a tool held still: where it is held)",
}
PRIVILEGED = {  # name -> what it is (units)
    "control_points": "the first intestine's spline control points (m, world), (n, 3)",
    "tool_forces": "each tool's force and torque from the tissue (N, N m), as the task's tool_forces",
    "grasper_holding": "1 where a grasper's jaws hold the bowel, per grasper",
    "held_abscissa": "the held point, m along the rest axis, per grasper (-1: not holding)",
}


@dataclasses.dataclass(eq=False)
class Episode:
    task: str
    scene: str
    seed: int                       # the task's seed: it fixes the episode's bowel, tissue, tilt and target
    demonstrator: str               # scripted, random, idle, or person:<device> / a recording's policy, file:NAME#SHA
    fps: int                        # control ticks per second
    state: np.ndarray               # (T + 1, D) float64, gymnasium's flat observation
    state_names: list[str]          # D names, "key[i]" (TaskEnv.observation_layout)
    action: np.ndarray              # (T, nu) float64 in [-1, 1], gymnasium's normalised action, as taken
    demonstrator_action: np.ndarray  # (T, nu) what the demonstrator commanded (= action without noise)
    action_names: list[str]         # the actuators
    reward: np.ndarray              # (T,) float64
    terminated: np.ndarray          # (T,) bool
    truncated: np.ndarray           # (T,) bool
    is_success: np.ndarray          # (T + 1,) bool, the task's lasting success after each tick
    images: dict[str, np.ndarray]   # pixels (T + 1, H, W, 3) uint8, depth float32 m, segmentation uint8
    privileged: dict[str, np.ndarray]  # PRIVILEGED's names, (T + 1, ...)
    # what a scripted oracle said it was doing at each action (viscera.tasks.oracle.Decision), empty
    # for other demonstrators: ORACLE_LABELS' names, (T, ...)
    oracle: dict[str, np.ndarray] = dataclasses.field(default_factory=dict)

    @property
    def steps(self) -> int:
        return len(self.action)

    @property
    def success(self) -> bool:
        return bool(self.is_success[-1])


def state_names(layout) -> list[str]:
    names = []
    for key, (part, shape) in layout.items():
        names += [f"{key}[{i}]" for i in range(part.stop - part.start)]
    return names


def _privileged(physics) -> dict[str, np.ndarray]:
    return {"control_points": physics.intestine().positions(physics.data.ptr).copy(),
            "tool_forces": np.asarray(physics.tool_forces(), dtype=np.float64).copy(),
            "grasper_holding": np.asarray(physics.holding(), dtype=np.float64).copy(),
            "held_abscissa": np.asarray(physics.held_abscissae(), dtype=np.float64).copy()}


def env_kwargs(task: str, scene: str, pixels: bool, size: tuple[int, int], camera: str = "laparoscope",
               control_timestep_s: float | None = None, time_limit_s: float | None = None) -> dict:
    """The TaskEnv arguments of a dataset's environment: flat state, the images beside it."""
    kwargs = {"task": task, "flatten": True, "scene": scene}
    if pixels:
        kwargs.update(pixels=True, height=int(size[0]), width=int(size[1]), camera=camera)
    if control_timestep_s is not None:
        kwargs["control_timestep"] = float(control_timestep_s)
    if time_limit_s is not None:
        kwargs["time_limit"] = float(time_limit_s)
    return kwargs


def env_spec(kwargs: dict):
    """gymnasium's spec of the task's registered id with these arguments (gymnasium.make(spec) rebuilds it)."""
    import gymnasium

    from viscera import gymnasium_ids

    gymnasium_ids.register()
    spec = gymnasium.spec(gymnasium_ids.env_ids()[kwargs["task"]])
    return dataclasses.replace(spec, kwargs=dict(kwargs))


NOISE_CORRELATION_S = 0.5  # s, the injected noise's correlation time: slower than the position servos


def run(env: TaskEnv, seed: int, demonstrator: str, actions: np.ndarray | None = None,
        action_noise: float = 0.0, policy=None, camera: np.ndarray | None = None, optics_deg: float = 0.0) -> Episode:
    """One episode of `env` from the task's `seed`, each action from `demonstrator` (DEMONSTRATORS;
    random draws from the seed), or from `policy` (a callable time step -> dm_env action, e.g. a
    policy file's, checked against `env`; `demonstrator` is then its name) or, given `actions` (a
    recording's dm_env actions), those in turn until they run out (the episode is then truncated
    there).

    action_noise: the standard deviation (in normalised action units) of noise added to every
    action taken, an Ornstein-Uhlenbeck process of NOISE_CORRELATION_S drawn from the seed, while
    the demonstrator keeps correcting from where the noise put the tools (DART, Laskey et al.
    2017): `demonstrator_action` keeps its commands, the labels a cloned policy learns from.

    camera: a recording's steered laparoscope (a pose per action, viscera.laparoscope, of
    `optics_deg`), set before each step as the session set it: the images are what it saw."""
    from viscera import recording

    dm_env = env.dm_env
    observation, info = env.reset(seed=seed)
    act = None if actions is not None else policy if policy is not None else \
        recording.policy_for(dm_env, demonstrator, seed)
    states, images = [], {k: [] for k in IMAGE_KEYS} if isinstance(observation, dict) else {}
    moves, labels, rewards, terminated, truncated = [], [], [], [], []
    said = []  # the oracle's decisions (a scripted demonstrator's)
    noise_rng = np.random.default_rng([int(seed), 0x5EED])
    noise = np.zeros(env.action_space.shape)
    decay = np.exp(-dm_env.control_timestep() / NOISE_CORRELATION_S)
    success, privileged = [info["is_success"]], {k: [] for k in PRIVILEGED}

    def keep(observation):
        if isinstance(observation, dict):
            states.append(observation["state"])
            for key in IMAGE_KEYS:
                images[key].append(observation[key])
        else:
            states.append(observation)
        for key, value in _privileged(dm_env.physics).items():
            privileged[key].append(value)

    keep(observation)
    scope = None
    if camera is not None:
        from viscera.laparoscope import Laparoscope
        scope = Laparoscope.of(dm_env.physics, optics_deg)
    time_step = env.time_step  # the FIRST dm_env time step: the policies act on time steps
    limit = len(actions) if actions is not None else None
    t = 0
    while True:
        # a demonstrator's NaN or wrong-sized command stops here, named, before it reaches MuJoCo
        dm_action = finite_array(f"action of {demonstrator} for seed {seed} at step {t}",
                                 actions[t] if actions is not None else act(time_step), env.action_space.shape)
        decision = getattr(act, "last", None) if actions is None else None
        if decision is not None:
            said.append(decision.vector(act.PHASES, act.names))
        label = action = np.clip(env.gym_action(dm_action), -1.0, 1.0)
        if action_noise > 0.0:
            noise = decay * noise + action_noise * np.sqrt(1.0 - decay ** 2) * noise_rng.standard_normal(noise.shape)
            action = np.clip(label + noise, -1.0, 1.0)
            dm_action = env.dm_action(action)
        # without noise the demonstrator's own command steps the simulation; the dataset keeps it normalised
        if scope is not None and t < len(camera):
            scope.apply(dm_env.physics, camera[t])
        time_step = dm_env.step(dm_action)
        t += 1
        done = time_step.last()
        ended_by_task = done and time_step.discount == 0.0
        cut = limit is not None and t >= limit and not done
        moves.append(action)
        labels.append(label)
        rewards.append(float(time_step.reward))
        terminated.append(ended_by_task)
        truncated.append((done and not ended_by_task) or cut)
        success.append(bool(dm_env.task.success(dm_env.physics)))
        keep(env.observation(time_step.observation))
        if done or cut:
            break
    env.end_episode()
    names = list(dm_env.physics.named.data.ctrl.axes.row.names)
    return Episode(
        task=env.task_name, scene=dm_env.task.scene.name,
        seed=int(seed), demonstrator=demonstrator, fps=int(round(1.0 / dm_env.control_timestep())),
        state=np.asarray(states, dtype=np.float64), state_names=state_names(env.observation_layout),
        action=np.asarray(moves, dtype=np.float64), demonstrator_action=np.asarray(labels, dtype=np.float64),
        action_names=names,
        reward=np.asarray(rewards, dtype=np.float64), terminated=np.asarray(terminated, dtype=bool),
        truncated=np.asarray(truncated, dtype=bool), is_success=np.asarray(success, dtype=bool),
        images={k: np.stack(v) for k, v in images.items()},
        privileged={k: np.stack(v) for k, v in privileged.items()},
        oracle=_oracle_labels(said) if len(said) == len(moves) else {})


def _oracle_labels(said: list[np.ndarray]) -> dict[str, np.ndarray]:
    """ORACLE_LABELS from the oracle's Decision.vector rows."""
    rows = np.asarray(said, dtype=np.float64)
    return {"phase": rows[:, 0].astype(np.int64), "lead": rows[:, 1].astype(np.int64),
            "aims": rows[:, 2:].reshape(len(rows), -1, 3)}

