"""The viscera tasks behind the gymnasium interface, with dm_env's semantics kept exact.

    import gymnasium as gym
    env = gym.make("viscera/ClearArea-v0")            # registered by import viscera (viscera.gymnasium_ids)
    envs = gym.make_vec("viscera/ClearArea-v0", num_envs=4, vectorization_mode="vector_entry_point")  # threads
    env = viscera.scale.gym_env.TaskEnv("clear_area", seed=0)

A thin adapter of ours rather than shimmy's DmControlCompatibilityV0: shimmy
imports gymnasium's MuJoCo renderer (imageio, GLFW) on import, re-seeds a
RandomState the dm_control task never reads, and offers only dict observations,
which CleanRL-style loops cannot batch into one tensor. Here:

- reset(seed=s) re-seeds the task's RandomState (what viscera.tasks.load(seed=s)
  does: the episode it draws, bowel, tissue, tilt and target, is then load(seed=s)'s
  first), then returns the FIRST time step's observation; its info carries
  step_type and is_success (dm_env's FIRST discount is None, which gymnasium could not batch
  beside floats). reset() without a seed draws the next episode.
- every info carries `is_success`, the task's lasting success (viscera.tasks: True once its
  condition has held long enough), the key stable-baselines3 and others read.
- render() with render_mode="rgb_array" draws through viscera's pixel camera (one RGB draw)
  from `render_camera` ("top" by default, or "laparoscope") at `render_size` (height, width).
- step's info carries step_type and discount, and the step's tissue-safety cost as `cost`
  (the key safe-RL libraries read) and `tissue_cost` (viscera.assess.step_cost: one per tool
  over the traction limit, per jaw over the slip-preventing pinch and over perforation).
- step returns the dm_env reward (float), and ends an episode exactly as dm_env
  does: a LAST step with discount 0 is `terminated` (the task ended it: the area is
  clear), a LAST step with discount > 0 is `truncated` (the time limit). Stepping
  past the end raises; dm_env would silently start a new episode instead.
- Observations are flat float64 vectors, the dm_env observation entries in the
  task's order (`observation_layout` gives each key's slice and shape); with
  flatten=False they are a gymnasium Dict of the same arrays. Nothing is cast,
  clipped or rescaled: values are bit-identical to the dm_env time step's.
- Actions are normalised to [-1, 1] per actuator, as RL libraries expect: -1 and 1
  are the ends of the actuator's control range (the dm_env action spec's bounds),
  mapped linearly; values outside are clipped to [-1, 1]. With
  normalize_actions=False they are the dm_env action itself (clamped by MuJoCo).
  A non-finite or wrong-sized action is refused by name before it reaches MuJoCo.
- Observation bounds are given where they are known: 0 to 1 for grasper_holding
  and target_coverage (and their slices of the flat vector), unbounded elsewhere.
- Pixels: TaskEnv(task, pixels=True, width=84, height=84) adds the camera's `pixels`
  (uint8 RGB), `depth` (float32 m) and `segmentation` (uint8 labels) to a Dict
  observation (flatten=False, the default then); with flatten=True the Dict holds
  `state`, the flat float64 vector of the other entries, beside the three images
  (never flattened into it; the layout viscera.datasets writes); pixels_only=True keeps
  the three images alone, for vision policies. viscera.pixels documents the camera, viscera.tasks.load the arguments.
"""

from __future__ import annotations

import collections

import gymnasium
import numpy as np
from dm_env import specs

import viscera.tasks
from viscera import assess
from viscera.scale import observations
from viscera.checks import checked_bool, finite_array
from viscera.pixels import LABELS


KNOWN_BOUNDS = {"grasper_holding": (0.0, 1.0), "target_coverage": (0.0, 1.0)}  # observation key -> low, high
IMAGE_KEYS = ("pixels", "depth", "segmentation")
IMAGE_BOUNDS = {"pixels": (0, 255), "depth": (0.0, np.inf), "segmentation": (0, max(LABELS.values()))}


def _box(spec, key: str | None = None) -> gymnasium.spaces.Box:
    if key in IMAGE_BOUNDS:
        return gymnasium.spaces.Box(*IMAGE_BOUNDS[key], spec.shape, spec.dtype)
    if key in KNOWN_BOUNDS:
        return gymnasium.spaces.Box(*KNOWN_BOUNDS[key], spec.shape, np.float64)
    if isinstance(spec, specs.BoundedArray):
        low = np.broadcast_to(spec.minimum, spec.shape).astype(spec.dtype)
        high = np.broadcast_to(spec.maximum, spec.shape).astype(spec.dtype)
        return gymnasium.spaces.Box(low, high, spec.shape, spec.dtype)
    return gymnasium.spaces.Box(-np.inf, np.inf, spec.shape, spec.dtype)


class TaskEnv(gymnasium.Env):
    """One viscera task (a dm_env.Environment) as a gymnasium.Env; see the module doc."""

    metadata = {"render_modes": ["rgb_array"]}

    def __init__(self, task: str = "clear_area", seed: int | None = None, flatten: bool | None = None,
                 render_mode: str | None = None, render_size: tuple[int, int] = (240, 320),
                 normalize_actions: bool = True, pixels_only: bool = False, render_camera: str = "top",
                 **task_kwargs):
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode = {render_mode!r}: must be None or 'rgb_array'")
        if (not isinstance(render_size, (tuple, list)) or len(render_size) != 2 or
                any(isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not 1 <= v <= 4096
                    for v in render_size)):
            raise ValueError(f"render_size = {render_size!r}: must be (height, width), integers from 1 to 4096 (pixels)")
        pixels_only = checked_bool("pixels_only", pixels_only)
        pixels = bool(task_kwargs.get("pixels", False))  # a value not True or False: refused by tasks.load
        if pixels_only and not pixels:
            raise ValueError("pixels_only = True needs pixels = True")
        if flatten is None:
            flatten = not pixels
        if flatten and pixels_only:
            raise ValueError("flatten = True with pixels_only = True: there is no state vector to flatten")
        self.task_name = task
        self.dm_env = viscera.tasks.load(task, seed=seed, **task_kwargs)
        self.flatten = flatten
        self.pixels_only = pixels_only
        self.render_mode = render_mode
        self.render_size = tuple(int(v) for v in render_size)  # (height, width) in pixels
        # render() draws through viscera's own camera (one RGB draw, the scene's quality settings
        # for observations) from `render_camera`: 'top', the whole cavity; 'laparoscope', the
        # surgeon's view. Made at the first render.
        self.render_camera = render_camera
        self._render_camera = None
        self.metadata = dict(self.metadata, render_fps=1.0 / self.dm_env.control_timestep())
        observation_spec = self.dm_env.observation_spec()
        if pixels_only:
            observation_spec = collections.OrderedDict((k, observation_spec[k]) for k in IMAGE_KEYS)
        if flatten:  # the state entries in one vector; with pixels, the images beside it, unflattened
            state_spec = collections.OrderedDict((k, v) for k, v in observation_spec.items() if k not in IMAGE_KEYS)
            self.observation_layout = observations.layout(state_spec)
            size = observations.size(self.observation_layout)
            low, high = np.full(size, -np.inf), np.full(size, np.inf)
            for key, (part, _) in self.observation_layout.items():
                if key in KNOWN_BOUNDS:
                    low[part], high[part] = KNOWN_BOUNDS[key]
            self.observation_space = gymnasium.spaces.Box(low, high, (size,), np.float64)
            if pixels:
                self.observation_space = gymnasium.spaces.Dict(collections.OrderedDict(
                    [("state", self.observation_space)] +
                    [(key, _box(observation_spec[key], key)) for key in IMAGE_KEYS]))
        else:
            self.observation_layout = observations.layout(observation_spec)
            self.observation_space = gymnasium.spaces.Dict(
                collections.OrderedDict((key, _box(spec, key)) for key, spec in observation_spec.items()))
        self.dm_action_space = _box(self.dm_env.action_spec())
        self.normalize_actions = normalize_actions
        self.action_space = gymnasium.spaces.Box(-1.0, 1.0, self.dm_action_space.shape, np.float64) \
            if normalize_actions else self.dm_action_space
        self._episode_over = True
        self.time_step = None  # the latest dm_env time step (reset's, then step's)

    def observation(self, dm_observation) -> np.ndarray | dict:
        """The gymnasium observation of a dm_env observation (flat: the entries concatenated in order)."""
        if self.pixels_only:
            return collections.OrderedDict((k, np.asarray(dm_observation[k])) for k in IMAGE_KEYS)
        if not self.flatten:
            return collections.OrderedDict((k, np.asarray(v)) for k, v in dm_observation.items())
        state = observations.flatten(dm_observation, self.observation_layout)
        if isinstance(self.observation_space, gymnasium.spaces.Dict):
            return collections.OrderedDict([("state", state)] + [(k, np.asarray(dm_observation[k])) for k in IMAGE_KEYS])
        return state

    def unflatten(self, observation: np.ndarray) -> dict:
        """The per-key arrays of a flat observation (views; also works on a batch, last axis flat)."""
        return observations.unflatten(observation, self.observation_layout)

    def _info(self, time_step) -> dict:
        """step_type; discount past the first step; is_success, the task's lasting success (the
        key stable-baselines3 and others read at an episode's end)."""
        success = bool(self.dm_env.task.success(self.dm_env.physics))
        if time_step.first():
            return {"step_type": int(time_step.step_type), "is_success": success}
        return {"step_type": int(time_step.step_type), "discount": float(time_step.discount), "is_success": success}

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        if seed is not None:
            viscera.tasks.reseed(self.dm_env, seed)
        self.time_step = time_step = self.dm_env.reset()
        self._episode_over = False
        return self.observation(time_step.observation), self._info(time_step)

    def step(self, action):
        if self._episode_over:
            raise RuntimeError("step() after the episode ended (or before reset()): call reset() first")
        action = finite_array("action", action, self.action_space.shape)
        self.time_step = time_step = self.dm_env.step(self.dm_action(action))
        terminated = truncated = False
        if time_step.last():
            self._episode_over = True
            terminated = time_step.discount == 0.0
            truncated = not terminated
        info = self._info(time_step)
        # the tissue-safety cost of the step's end (viscera.assess.step_cost), under the key safe-RL
        # libraries read (safety-gymnasium, OmniSafe), and under its own name
        info["cost"] = info["tissue_cost"] = assess.step_cost(self.dm_env.physics)
        return (self.observation(time_step.observation), float(time_step.reward), terminated, truncated, info)

    def end_episode(self) -> None:
        """Mark the episode over (for a caller that stepped `dm_env` itself): step() then needs a reset()."""
        self._episode_over = True

    def dm_action(self, action: np.ndarray) -> np.ndarray:
        """The dm_env action (actuator controls) of a gymnasium action."""
        if not self.normalize_actions:
            return action
        low, high = self.dm_action_space.low, self.dm_action_space.high
        return low + 0.5 * (np.clip(action, -1.0, 1.0) + 1.0) * (high - low)

    def gym_action(self, dm_action: np.ndarray) -> np.ndarray:
        """The gymnasium action of a dm_env action (e.g. a scripted policy's)."""
        if not self.normalize_actions:
            return np.asarray(dm_action, dtype=np.float64)
        low, high = self.dm_action_space.low, self.dm_action_space.high
        return 2.0 * (np.asarray(dm_action, dtype=np.float64) - low) / (high - low) - 1.0

    def close(self) -> None:
        """Free the pixel cameras' rendering contexts (see viscera.tasks.close)."""
        viscera.tasks.close(self.dm_env)
        if self._render_camera is not None:
            self._render_camera.close()
        super().close()

    def render(self):
        """The current frame (height, width, 3) uint8 RGB from `render_camera` at `render_size`, with
        render_mode 'rgb_array'; None otherwise."""
        if self.render_mode != "rgb_array":
            return None
        if self._render_camera is None:
            from viscera.pixels import Camera
            height, width = self.render_size
            self._render_camera = Camera(width, height, self.render_camera)
        return self._render_camera.render_rgb(self.dm_env.physics)
