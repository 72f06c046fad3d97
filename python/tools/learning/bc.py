"""Behaviour cloning from the scripted demonstrations, on every task from the state observations
and on grasp_lift also from the laparoscope's pixels: ACT-style action chunks with temporal
ensembling, DAgger with the scripted expert where it helps; each policy written as a policy file
(viscera.policy_file) and evaluated through that file on 50 seeds no demonstration used, with the
assessment's scores; written to docs/learning/bc.json (its figure docs/learning/bc.png) and
docs/learning/policies/TASK_KIND.npz.

    pip install ".[learning]"
    python python/tools/learning/bc.py [--tasks clear_area grasp_lift ...] [--observations state pixels]
        [--pixel-tasks grasp_lift] [--demos-state N] [--demos-pixels N] [--data data/demos]
        [--eval-seeds 2000:2050] [--curve-seeds 2000:2020] [--chunk 50] [--dagger-rounds 4] [--workers 1]
        [--out docs/learning/bc.json]

- The demonstrations: `python -m viscera dataset TASK --policy scripted --seeds 0:N --format minari
  [--pixels] --out DATA/KIND/TASK` (this script writes them when missing), read back with
  Minari's loader; N is DEMOS's (500 for grasp_lift's state, 200 for the others', 100 with
  pixels). Only the demonstrations that succeeded are cloned.
- What a policy sees, never the privileged state:
  - `state`: gymnasium's flat state observation (the task's own entries: tool joints and forces,
    the grasp, the intestine's axis points, gravity, the task's target);
  - `pixels`: the laparoscope's 84 x 84 RGB and the tools' joints (what a robot knows of itself);
  - both also get the policy's own memory: its clock (the control steps it has taken, as a
    fraction of the time limit) and its previous command. The demonstrator's phases are timed and
    its commands are velocity-limited ramps, which the tools' measured joints lag behind: without
    them a cloned policy cannot tell where along a ramp it is.
- The model (ACT's action chunks, Zhao et al., RSS 2023, on an MLP, or on a pixel encoder of two
  convolutions and a spatial softmax's keypoints, Levine et al., JMLR 2016): at each step it
  predicts the next `chunk` commands (normalised, as the actions are), trained on every frame's
  next `chunk` labels (the last repeated past an episode's end). At play time the command of a
  step is the weighted mean of every chunk's prediction for it (temporal ensembling, weights
  exp(-m x age); m < 0 weighs the older predictions more, as ACT does).
- DAgger (Ross, Gordon and Bagnell, AISTATS 2011), DAGGER_ROUNDS by task: each round runs the
  learner on seeds after the demonstrations' with the scripted oracle alongside (viscera.tasks.oracle:
  it decides from the state it is handed alone), and records the oracle's command as the label of
  every state the learner reached. Who acts is drawn every
  `segment` steps: the script with probability beta, else the learner. The network is then trained
  further on all the frames so far.
- Training: Adam on one CPU thread; L1 loss (ACT's); pixels shifted by up to 4 pixels at random
  (DrQ's augmentation). Evaluation: the policy file, loaded, acting as `python -m viscera play
  TASK --policy FILE` plays it. CPU time is measured for training, DAgger and the evaluations
  (the curve's core-hours); collecting the demonstrations is measured only when this run collects
  them.
"""

from __future__ import annotations

import argparse
import concurrent.futures
import dataclasses
import json
import multiprocessing
import pathlib
import sys
import tempfile
import time

import numpy as np
import torch
from torch import nn

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import common  # noqa: E402

OUT = pathlib.Path("docs") / "learning" / "bc.json"
POLICIES = pathlib.Path("docs") / "learning" / "policies"
TASKS = ("clear_area", "grasp_lift", "retract_reach", "run_the_bowel")
# the state entries a pixel policy also gets: what the robot knows of itself (its joints, last
# commands, the tissue's wrench on each tool, the hold) and of its view (the scope's pose)
PROPRIOCEPTION = ("tool_joints", "tool_command", "tool_forces", "grasper_holding", "camera_pose")
IMAGE_SIZE = (84, 84)
# the tasks cloned from pixels as well: grasp_lift, whose state clone succeeds; the others' state
# clones reach 0-35 %, and from pixels they reached 0 % in the previous release
PIXEL_TASKS = ("grasp_lift",)
# demonstrations per policy: pixels cost 6 ms a frame to collect; grasp_lift's episodes are short
# (about 185 steps), and 500 of them took its clone from 55 % to 85 % on seeds 2000-2019
DEMOS = {"state": {"clear_area": 200, "grasp_lift": 1500, "retract_reach": 200, "run_the_bowel": 200},
         "pixels": {"clear_area": 100, "grasp_lift": 300, "retract_reach": 100, "run_the_bowel": 100}}
FRAME_KEYS = ("state", "pixels", "clock", "previous_action", "action", "decision")
MEMORY_CLIP = 5.0  # a policy's memory (normalised decision features) is clipped to this
AIM_FLOOR_M = 0.01  # an aim's coordinates are normalised by their spread, never below 1 cm


@dataclasses.dataclass(frozen=True)
class Method:
    """The learner's settings (one per kind of observation: METHOD)."""

    chunk: int = 50                    # K: commands predicted at each step (1 s at 50 Hz)
    ensemble_m: float = -0.05          # temporal ensembling: a prediction of age a weighs exp(-m a)
    hidden: tuple[int, ...] = (192, 192)   # the MLP's hidden layers (after the pixel encoder, if any)
    conv: tuple[tuple[int, int, int], ...] = ()  # the pixel encoder's layers: (channels, kernel, stride)
    pooling: str = "flatten"           # the pixel encoder's last step: "flatten" or "spatial_softmax"
    batch: int = 256
    learning_rate: float = 1e-3
    final_learning_rate: float = 1e-5  # each training's rate falls to this along a cosine
    loss: str = "l1"                   # "l1" (ACT's) or "mse"
    target: str = "action"             # "action": the command; "change": from the previous command (a jaw's: itself)
    updates: int = 20_000              # Adam steps on the demonstrations
    dagger_rounds: int = 0
    dagger_episodes: int = 20          # the learner's episodes per round
    dagger_updates: int = 3_000        # Adam steps after each round, on every frame so far
    beta: float = 0.5                  # the script's share of control in DAgger's first round, falling
                                       # linearly to 0 at the last (the learner alone, the oracle labelling)
    segment: int = 25                  # control steps between draws of who acts
    dagger_noise: float = 0.0          # DAgger's executed commands moved by normal noise of this share of
                                       # each actuator's range, so that the oracle labels the states noise
                                       # leads to (DART, Laskey et al. 2017), reading the command the actor
                                       # meant to send. Off: on grasp_lift, 3 rounds of 40 at 0.02 gave 82 %
                                       # from the state (78 % under that noise), 50 % from pixels (15 %),
                                       # where the clones without DAgger give 87 % (85 %) and 77 % (31 %)
    shift: int = 0                     # pixels: random shifts of up to this many pixels (0: none)
    previous: bool = True              # the previous command among the inputs
    previous_noise: float = 0.0        # training moves the previous-command input by normal noise of this
                                       # size (normalised units: 0.04 is 2 % of a range), as action noise
                                       # sets the executed command (the state's) apart from the one sent
    memory: bool = False               # the network also says what the oracle is doing (its phase and
                                       # lead tool, one-hot, and each tool's aim, normalised), trained on
                                       # the oracle's labels, and reads what it said at the step before
    memory_weight: float = 1.0         # the memory's loss beside the actions' (L1 both)
    memory_noise: float = 0.1          # training feeds the oracle's previous labels, moved by normal
                                       # noise of this size, where acting feeds the network's own


METHOD = {
    "state": Method(),
    # keypoints: a spatial softmax over an 18 x 18 map (where the band and the jaws are), as robot
    # learning from pixels does (Levine et al. 2016; robomimic)
    # the previous command noised as 2 % action noise sets the executed one apart: 81 % (39 % under that
    # noise) where it was 77 % (31 %), on grasp_lift's seeds 2000-2099
    "pixels": Method(hidden=(256,), conv=((16, 8, 4), (32, 3, 1)), pooling="spatial_softmax", batch=128,
                     updates=8_000, shift=4, previous_noise=0.04),
}
# DAgger rounds by task: clear_area's clone drifts from the demonstrations' states and gains from
# the script's labels there (15 % to 35 % on seeds 2000-2019, docs/learning/bc_variants.json);
# on grasp_lift, retract_reach and run_the_bowel the rounds did not help (grasp_lift 60 % before
# and after; the other two 0-5 % throughout), and they cost a core-hour a task
DAGGER_ROUNDS = {"clear_area": 4, "grasp_lift": 0, "retract_reach": 0, "run_the_bowel": 0}


def proprioception_slices(names: list[str]) -> np.ndarray:
    """Indices of the state vector's PROPRIOCEPTION entries (names "key[i]")."""
    return np.array([i for i, name in enumerate(names) if name.split("[")[0] in PROPRIOCEPTION])


def environment(task: str, pixels: bool):
    """The gymnasium TaskEnv the demonstrations were collected in (flat state, the images beside it)."""
    from viscera.datasets import episodes
    from viscera.scale.gym_env import TaskEnv

    return TaskEnv(**episodes.env_kwargs(task, "abdomen", pixels, IMAGE_SIZE))


def time_limit_steps(env) -> int:
    return int(round(env.dm_env.time_limit_s / env.dm_env.control_timestep()))


# -- frames: the (input, label) pairs, episode after episode

def decision_features(rows: np.ndarray, phases: int, tools: int) -> np.ndarray:
    """Oracle Decision.vector rows [phase index, lead index, aims (m) ...] as features: the phase
    and the lead tool one-hot, then the aims as they are (float32)."""
    rows = np.asarray(rows, dtype=np.float64).reshape(len(rows), -1)
    out = np.zeros((len(rows), phases + tools + rows.shape[1] - 2), dtype=np.float32)
    out[np.arange(len(rows)), rows[:, 0].astype(int)] = 1.0
    out[np.arange(len(rows)), phases + rows[:, 1].astype(int)] = 1.0
    out[:, phases + tools:] = rows[:, 2:]
    return out


def frames_of(episodes: list[dict], names: list[str], action_names: list[str], limit_steps: int) -> dict:
    """The frames of `episodes` (each: state, pixels or None, previous_action, action: the labels)
    concatenated, with `end`: each frame's episode's last frame, where its chunks stop."""
    frames = {key: None for key in FRAME_KEYS}
    for key in FRAME_KEYS:
        parts = [e[key] for e in episodes]
        if parts and parts[0] is not None:
            frames[key] = np.concatenate(parts)
    for key in ("state", "clock", "previous_action", "action"):
        frames[key] = frames[key].astype(np.float32)
    lengths = [len(e["action"]) for e in episodes]
    frames["end"] = np.repeat(np.cumsum(lengths) - 1, lengths)
    frames["first"] = np.repeat(np.cumsum(lengths) - lengths, lengths)  # each frame's episode's first frame
    frames.update(names=names, action_names=action_names, time_limit_steps=limit_steps, episodes=len(episodes))
    return frames


def aggregate(frames: dict, more: dict) -> dict:
    """DAgger's aggregate: the frames of both."""
    joined = dict(frames)
    for key in FRAME_KEYS:
        if frames[key] is not None:
            joined[key] = np.concatenate([frames[key], more[key]])
    joined["end"] = np.concatenate([frames["end"], more["end"] + len(frames["action"])])
    joined["first"] = np.concatenate([frames["first"], more["first"] + len(frames["action"])])
    joined["episodes"] = frames["episodes"] + more["episodes"]
    return joined


def oracle_features(oracle, task: str, steps: int) -> np.ndarray | None:
    """A Minari episode's infos["oracle"] (a row per observation, the reset's first) as the
    decision_features of its `steps` actions; None without them."""
    if not oracle:
        return None
    import viscera.tasks

    aims = np.asarray(oracle["aims"])[1:steps + 1]
    rows = np.concatenate([np.asarray(oracle["phase"])[1:steps + 1, None], np.asarray(oracle["lead"])[1:steps + 1, None],
                           aims.reshape(steps, -1)], axis=1)
    return decision_features(rows, len(viscera.tasks.oracle_phases(task)), aims.shape[1])


def load_demonstrations(root: pathlib.Path, task: str, pixels: bool, limit: int | None = None) -> dict:
    """The successful demonstrations' frames (frames_of), read with Minari's loader."""
    from viscera import datasets

    dataset = datasets.load(root, "minari", task, "scripted")
    env = environment(task, pixels)
    names = common.state_names(env)
    action_names = list(env.dm_env.physics.named.data.ctrl.axes.row.names)
    limit_steps = time_limit_steps(env)
    env.close()
    episodes, seeds = [], []
    metadata = list(dataset.storage.get_episode_metadata(dataset.episode_indices))
    for episode, meta in zip(dataset.iterate_episodes(), metadata):
        if not episode.infos["is_success"][-1]:
            continue
        if limit is not None and len(episodes) >= limit:
            break
        seeds.append(int(meta["seed"]))
        steps = len(episode.actions)
        observation = episode.observations
        labels = episode.infos["demonstrator_action"][1:] if "demonstrator_action" in episode.infos else episode.actions
        episodes.append({
            "state": np.asarray(observation["state"][:steps] if isinstance(observation, dict) else observation[:steps],
                                dtype=np.float32),
            "pixels": observation["pixels"][:steps] if pixels else None,
            "clock": np.arange(steps, dtype=np.float32) / limit_steps,
            "action": np.asarray(labels, dtype=np.float32),  # what the script commanded
            # the policy's own previous command (the action taken, noise and all): zeros before the first
            "previous_action": np.concatenate([np.zeros_like(episode.actions[:1]), episode.actions[:-1]]).astype(
                np.float32),
            "decision": oracle_features(episode.infos.get("oracle"), task, steps)})
    if not episodes:
        raise SystemExit(f"{root}: no successful demonstration to clone")
    if episodes[0]["state"].shape[1] != len(names):  # a dataset of another observation layout
        raise SystemExit(f"{root}: its states hold {episodes[0]['state'].shape[1]} values, {task}'s observation "
                         f"{len(names)} ({', '.join(sorted({n.split('[')[0] for n in names}))}): collected by another "
                         "viscera; move it away to collect again")
    if len({e["decision"] is None for e in episodes}) > 1:
        raise SystemExit(f"{root}: some episodes hold the oracle's labels and some do not")
    frames = frames_of(episodes, names, action_names, limit_steps)
    frames.update(seeds=seeds, total_episodes=dataset.total_episodes, collected_steps=int(dataset.total_steps))
    return frames


# -- the network

class Network(nn.Module):
    """An MLP over [pixel features,] state, clock and previous command, giving `chunk` x action size
    values; the pixel encoder is a stack of unpadded ReLU convolutions, flattened."""

    def __init__(self, state_size: int, action_size: int, method: Method, pixels: bool, memory_size: int = 0):
        super().__init__()
        features = 0
        self.conv = None
        if pixels:
            layers, channels = [], 3
            for i, (out, kernel, stride) in enumerate(method.conv):
                layers.append(nn.Conv2d(channels, out, kernel, stride=stride))
                # keypoints' maps stay signed: the softmax takes the last layer as it is
                if not (method.pooling == "spatial_softmax" and i == len(method.conv) - 1):
                    layers.append(nn.ReLU())
                channels = out
            pooling = SpatialSoftmax() if method.pooling == "spatial_softmax" else nn.Flatten()
            self.conv = nn.Sequential(*layers, pooling)
            with torch.no_grad():
                features = self.conv(torch.zeros(1, 3, *IMAGE_SIZE)).shape[1]
        layers, width = [], features + state_size + 1 + (action_size if method.previous else 0) + memory_size
        for size in method.hidden:
            layers += [nn.Linear(width, size), nn.ReLU()]
            width = size
        self.mlp = nn.Sequential(*layers, nn.Linear(width, method.chunk * action_size + memory_size))

    def forward(self, state, memory, image=None):
        parts = [state, memory] if self.conv is None else [self.conv(image), state, memory]
        return self.mlp(torch.cat(parts, dim=1))


class SpatialSoftmax(nn.Module):
    """(B, C, H, W) maps -> (B, 2 C): each channel's softmax over its positions, then its expected
    column and row coordinates, -1 to 1 across the map (viscera.policy_file's "spatial_softmax")."""

    def forward(self, maps):
        count, channels, height, width = maps.shape
        weights = torch.softmax(maps.reshape(count, channels, height * width), dim=-1)
        columns = torch.linspace(-1.0, 1.0, width).repeat(height)
        rows = torch.linspace(-1.0, 1.0, height).repeat_interleave(width)
        return torch.stack([(weights * columns).sum(-1), (weights * rows).sum(-1)], dim=-1).reshape(count, -1)


def shifted(images: torch.Tensor, shift: int, generator: torch.Generator) -> torch.Tensor:
    """DrQ's augmentation: each image (B, C, H, W) moved by up to `shift` pixels, its edges repeated."""
    if not shift:
        return images
    count, _, height, width = images.shape
    padded = nn.functional.pad(images, (shift, shift, shift, shift), mode="replicate")
    dy, dx = torch.randint(0, 2 * shift + 1, (2, count), generator=generator)
    rows = (torch.arange(height)[None, :] + dy[:, None])[:, None, :, None].expand(-1, images.shape[1], -1, width + 2 * shift)
    out = torch.gather(padded, 2, rows)
    cols = (torch.arange(width)[None, :] + dx[:, None])[:, None, None, :].expand(-1, images.shape[1], height, -1)
    return torch.gather(out, 3, cols)


class Learner:
    """The network with its input normalisation, output scale and optimiser, trained on frames,
    acting (Cloned) and written as a policy file."""

    def __init__(self, frames: dict, kind: str, method: Method, seed: int = 0):
        torch.manual_seed(seed)
        torch.set_num_threads(1)
        self.kind, self.method = kind, method
        self.generator = torch.Generator().manual_seed(seed)
        self.inputs = np.arange(frames["state"].shape[1]) if kind == "state" else proprioception_slices(frames["names"])
        state = frames["state"][:, self.inputs].astype(np.float64)
        # float32 as the policy file keeps them, so that training and the file normalise alike; each
        # entry's scale is its spread in the demonstrations, but never below its unit's floor
        # (common.observation_floors), and the normalised entries are clipped (common.INPUT_CLIP)
        floors = common.observation_floors([frames["names"][i] for i in self.inputs], frames["action_names"])
        self.mean = state.mean(axis=0).astype(np.float32)
        self.scale = np.maximum(state.std(axis=0), floors).astype(np.float32)
        self.action_names = frames["action_names"]
        # an actuator no demonstration moved (grasp_lift's roll) is held where they held it, not learned
        labels = frames["action"].astype(np.float64)
        self.held = np.flatnonzero(labels.max(axis=0) - labels.min(axis=0) < 1e-3)
        self.held_values = labels[0, self.held] if len(self.held) else np.zeros(0)
        self.jaws = np.array([name.endswith("_jaw") for name in self.action_names])
        self.time_limit_steps = frames["time_limit_steps"]
        # the target's scale: the spread, per actuator, of the change from the previous command
        # to each of the next `chunk` labels (a jaw: of its label)
        sample = np.random.default_rng(seed).integers(len(frames["action"]), size=min(20_000, len(frames["action"])))
        target = self._targets(frames, torch.as_tensor(sample)).numpy()
        # (at least 1 % of the normalised range: an actuator the demonstrations never moved, whose
        # labels elsewhere, DAgger's, may differ a little, must not blow its loss up)
        self.change_scale = np.maximum(target.reshape(-1, target.shape[-1]).std(axis=0), 1e-2).astype(np.float32)
        self.memory_size = 0
        if method.memory:  # the decision features normalised: one-hots as they are, aims by their spread
            if frames.get("decision") is None:
                raise SystemExit("memory: the demonstrations hold no oracle labels (collected by an older viscera?)")
            decision = frames["decision"].astype(np.float64)
            one_hot = np.all((decision == 0.0) | (decision == 1.0), axis=0)
            self.decision_mean = np.where(one_hot, 0.0, decision.mean(axis=0)).astype(np.float32)
            self.decision_scale = np.where(one_hot, 1.0, np.maximum(decision.std(axis=0), AIM_FLOOR_M)).astype(np.float32)
            self.memory_size = decision.shape[1]
        self.model = Network(len(self.inputs), len(self.action_names), method, kind == "pixels", self.memory_size)
        self.optimiser = torch.optim.Adam(self.model.parameters(), lr=method.learning_rate)
        self.losses: list[float] = []

    def _targets(self, frames: dict, index: torch.Tensor) -> torch.Tensor:
        """The unscaled targets (B, chunk, actions) of frames `index`: the next `chunk` labels, less
        the previous command (a jaw's label as it is)."""
        later = torch.minimum(index[:, None] + torch.arange(self.method.chunk)[None, :],
                              torch.as_tensor(frames["end"])[index][:, None])
        labels = torch.as_tensor(frames["action"])[later]
        previous = torch.as_tensor(frames["previous_action"])[index][:, None, :]
        if self.method.target == "action":
            return labels
        return torch.where(torch.as_tensor(self.jaws), labels, labels - previous)

    def fit(self, frames: dict, updates: int) -> tuple[float, float]:
        """`updates` Adam steps on batches of `frames`; the wall and CPU seconds they took."""
        torch.set_num_threads(1)
        method = self.method
        self.model.train()
        wall, cpu = time.perf_counter(), time.process_time()
        state = torch.as_tensor(np.clip((frames["state"][:, self.inputs] - self.mean) / self.scale,
                                        -common.INPUT_CLIP, common.INPUT_CLIP), dtype=torch.float32)
        memory = torch.as_tensor(np.concatenate([frames["clock"][:, None]] +
                                                ([frames["previous_action"]] if method.previous else []), axis=1),
                                 dtype=torch.float32)
        images = torch.as_tensor(frames["pixels"]) if self.kind == "pixels" else None  # uint8, scaled per batch
        scale = torch.as_tensor(self.change_scale)
        decision = first = None
        if self.memory_size:  # the target: this step's decision; the input: the step before's (zeros at the first)
            decision = torch.as_tensor(self.normalised_decision(frames["decision"]), dtype=torch.float32)
            first = torch.as_tensor(frames["first"])
        actions = method.chunk * len(self.action_names)
        for update in range(updates):
            for group in self.optimiser.param_groups:
                group["lr"] = method.final_learning_rate + 0.5 * (method.learning_rate - method.final_learning_rate) * (
                    1.0 + np.cos(np.pi * update / updates))
            index = torch.randint(len(state), (method.batch,), generator=self.generator)
            image = None
            if images is not None:
                image = shifted(images[index].permute(0, 3, 1, 2).float() / 255.0, method.shift, self.generator)
            target = self._targets(frames, index) / scale
            target[:, :, self.held] = 0.0  # a held actuator's command is the file's, not learned
            target = target.reshape(method.batch, -1)
            given = memory[index]  # the clock, then the previous command
            if method.previous and method.previous_noise:
                given[:, 1:] += method.previous_noise * torch.randn(len(index), given.shape[1] - 1,
                                                                    generator=self.generator)
            if decision is not None:
                later = (index > first[index])[:, None]  # an episode's first frame reads zeros, as acting does
                before = torch.where(later, decision[torch.clamp(index - 1, min=0)]
                                     + method.memory_noise * torch.randn(later.shape[0], decision.shape[1],
                                                                         generator=self.generator), 0.0)
                given = torch.cat([given, before], dim=1)
            out = self.model(state[index], given, image)
            error = out[:, :actions] - target
            error = error.reshape(method.batch, method.chunk, -1)
            error[:, :, self.held] = 0.0
            error = error.reshape(method.batch, -1)
            loss = error.abs().mean() if method.loss == "l1" else (error ** 2).mean()
            if decision is not None:
                loss = loss + method.memory_weight * (out[:, actions:] - decision[index]).abs().mean()
            self.optimiser.zero_grad()
            loss.backward()
            self.optimiser.step()
            self.losses.append(float(loss.detach()))
        self.model.eval()
        return time.perf_counter() - wall, time.process_time() - cpu

    def normalised_decision(self, features: np.ndarray) -> np.ndarray:
        """Decision features (decision_features) as the memory holds them, clipped to MEMORY_CLIP."""
        return np.clip((features - self.decision_mean) / self.decision_scale, -MEMORY_CLIP, MEMORY_CLIP)

    def policy(self, ensemble_m: float | None = None) -> "Cloned":
        return Cloned(self, self.method.ensemble_m if ensemble_m is None else ensemble_m)

    # -- the policy file

    def architecture(self, ensemble_m: float) -> tuple[dict, dict]:
        """The policy file's architecture (viscera.policy_file) and its named float32 arrays."""
        weights = {"state_mean": self.mean, "state_scale": self.scale, "output_scale": self.change_scale}
        inputs = ["state", "clock"] + (["previous_action"] if self.method.previous else [])
        architecture = {"kind": "mlp", "inputs": inputs,
                        "state_normalisation": {"mean": "state_mean", "scale": "state_scale",
                                                "clip": common.INPUT_CLIP},
                        "clock_steps": self.time_limit_steps}
        if self.method.previous:
            architecture["previous_action_start"] = "zeros"
        if self.memory_size:
            inputs.append("memory")
            architecture["memory"] = {"size": self.memory_size, "clip": MEMORY_CLIP}
        if self.model.conv is not None:
            architecture["inputs"] = ["pixels"] + inputs
            layers = []
            modules = list(self.model.conv)
            convs = [j for j, m in enumerate(modules) if isinstance(m, nn.Conv2d)]
            for i, j in enumerate(convs):
                conv = modules[j]
                weights[f"conv{i}.weight"] = conv.weight.detach().numpy().astype(np.float32)
                weights[f"conv{i}.bias"] = conv.bias.detach().numpy().astype(np.float32)
                relu = isinstance(modules[j + 1], nn.ReLU)
                layers.append({"kind": "conv2d", "weight": f"conv{i}.weight", "bias": f"conv{i}.bias",
                               "stride": int(conv.stride[0]), "activation": "relu" if relu else "none"})
            architecture["pixel_encoder"] = {"scale": 255.0, "layers": layers, "pooling": self.method.pooling}
        dense = [m for m in self.model.mlp if isinstance(m, nn.Linear)]
        architecture["layers"] = []
        for i, linear in enumerate(dense):
            weights[f"dense{i}.weight"] = linear.weight.detach().numpy().astype(np.float32)
            weights[f"dense{i}.bias"] = linear.bias.detach().numpy().astype(np.float32)
            architecture["layers"].append({"kind": "dense", "weight": f"dense{i}.weight", "bias": f"dense{i}.bias",
                                           "activation": "relu" if i < len(dense) - 1 else "none"})
        output = {"target": self.method.target, "scale": "output_scale", "chunk": self.method.chunk}
        if self.method.target == "change":
            output["absolute"] = [int(i) for i in np.flatnonzero(self.jaws)]
        if self.method.chunk > 1:
            output["temporal_ensemble_m"] = float(ensemble_m)
        if len(self.held):
            output["held"] = {"indices": [int(i) for i in self.held], "values": [float(v) for v in self.held_values]}
        architecture["output"] = output
        return architecture, weights

    def save(self, path: pathlib.Path, task: str, ensemble_m: float | None = None, training: dict | None = None):
        """Write the policy file (viscera.policy_file.save) and check that it gives the network's
        commands; the loaded LearnedPolicy."""
        from viscera import policy_file

        ensemble_m = self.method.ensemble_m if ensemble_m is None else ensemble_m
        env = environment(task, self.kind == "pixels")
        try:
            keys = list(PROPRIOCEPTION) if self.kind == "pixels" else None
            fields = policy_file.describe(env.dm_env, state=keys, pixels=self.kind == "pixels")
            if fields["action"]["names"] != self.action_names:
                raise RuntimeError(f"{task}: the environment's actuators {fields['action']['names']} are not the "
                                   f"demonstrations' {self.action_names}")
            architecture, weights = self.architecture(ensemble_m)
            path.parent.mkdir(parents=True, exist_ok=True)
            loaded = policy_file.save(path, weights=weights, architecture=architecture, training=training or {},
                                      **fields)
            self._check_file(loaded, env)
        finally:
            env.close()
        return loaded

    def _check_file(self, loaded, env, steps: int = 30) -> None:
        """That the file's inference (float64 NumPy on the float32 weights) gives the network's
        commands, on the first steps of an episode driven by the file."""
        cloned = self.policy(loaded.meta["architecture"]["output"].get("temporal_ensemble_m"))
        observation, _ = env.reset(seed=0)
        loaded.reset()
        worst = 0.0
        for _ in range(steps):
            mine = cloned(observation)
            theirs = loaded.act(loaded.state_of(env.time_step.observation),
                                env.time_step.observation["pixels"] if self.kind == "pixels" else None)
            worst = max(worst, float(np.max(np.abs(mine - theirs))))
            observation, *_ = env.step(theirs)
            cloned.previous = theirs  # each follows the file's commands
        env.end_episode()
        if worst > 1e-3:
            raise RuntimeError(f"{loaded.path}: the file's commands differ from the network's by {worst:.2g}")


class Cloned:
    """A learner's policy as `act(observation)` on a gymnasium observation (flat, or a Dict with
    pixels), giving the normalised command: the same inference as its policy file (chunks,
    temporal ensembling, the clock and the previous command), in torch. `previous` is settable:
    DAgger's mixture sets it to the command the script executed."""

    def __init__(self, learner: Learner, ensemble_m: float):
        self.learner = learner
        chunk = learner.method.chunk
        self.weights = np.exp(-ensemble_m * np.arange(chunk)) if chunk > 1 else np.ones(1)
        self.mean, self.scale = learner.mean.astype(np.float64), learner.scale.astype(np.float64)
        self.change_scale = learner.change_scale.astype(np.float64)
        self.reset()

    def reset(self) -> None:
        self.step = 0
        self.previous = np.zeros(len(self.learner.action_names))
        self.memory = np.zeros(self.learner.memory_size)  # what the network said at the step before
        self.chunks: list[tuple[int, np.ndarray]] = []

    def predict(self, observation) -> np.ndarray:
        """The chunk (chunk, actions) of commands predicted at this step, clipped to [-1, 1]."""
        learner = self.learner
        state = observation["state"] if isinstance(observation, dict) else observation
        state = np.clip((np.asarray(state, dtype=np.float64)[learner.inputs] - self.mean) / self.scale,
                        -common.INPUT_CLIP, common.INPUT_CLIP)
        memory = np.concatenate([[self.step / learner.time_limit_steps]] +
                                ([self.previous] if learner.method.previous else []) + [self.memory])
        image = None
        if learner.kind == "pixels":
            image = torch.as_tensor(np.ascontiguousarray(observation["pixels"]),
                                    dtype=torch.float32).permute(2, 0, 1)[None] / 255.0
        with torch.no_grad():
            raw = learner.model(torch.as_tensor(state, dtype=torch.float32)[None],
                                torch.as_tensor(memory, dtype=torch.float32)[None], image)
        raw = raw[0].numpy().astype(np.float64)
        actions = learner.method.chunk * len(learner.action_names)
        self.memory = np.clip(raw[actions:], -MEMORY_CLIP, MEMORY_CLIP)
        raw = raw[:actions].reshape(learner.method.chunk, -1) * self.change_scale
        if learner.method.target == "change":
            raw = np.where(learner.jaws, raw, self.previous + raw)
        raw[:, learner.held] = learner.held_values
        return np.clip(raw, -1.0, 1.0)

    def __call__(self, observation) -> np.ndarray:
        self.chunks.append((self.step, self.predict(observation)))
        self.chunks = self.chunks[-len(self.weights):]
        total, command = 0.0, np.zeros_like(self.previous)
        for made, chunk in self.chunks:
            age = self.step - made
            command = command + self.weights[age] * chunk[age]
            total += self.weights[age]
        self.previous = np.clip(command / total, -1.0, 1.0)
        self.step += 1
        return self.previous.copy()


def train(data: dict, kind: str, updates: int, seed: int = 0, method: Method | None = None) -> tuple:
    """Behaviour cloning alone: the trained policy (Cloned), the training's wall and CPU seconds
    and its last loss."""
    method = dataclasses.replace(method or METHOD[kind], updates=updates)
    learner = Learner(data, kind, method, seed)
    wall, cpu = learner.fit(data, updates)
    return learner.policy(), wall, cpu, float(np.mean(learner.losses[-100:]))


# -- DAgger

def _dagger_episodes(policy: Cloned, task: str, kind: str, seeds: list[int], beta: float, segment: int,
                     draw_seed: int, noise: float = 0.0) -> list[dict]:
    """The learner's episodes on `seeds` with a fresh script alongside each, its commands the labels;
    who acts drawn every `segment` steps (the script with probability beta); each executed command
    moved by normal noise of `noise` of its range (the actor remembers its own command)."""
    import viscera.tasks

    torch.set_num_threads(1)
    env = environment(task, kind == "pixels")
    if kind == "pixels":
        env.dm_env.task.camera = RGBOnly(env.dm_env.task.camera)
    limit_steps = time_limit_steps(env)
    rng = np.random.default_rng(draw_seed)
    episodes = []
    try:
        for seed in seeds:
            observation, info = env.reset(seed=int(seed))
            expert = viscera.tasks.scripted_policy(env.dm_env)  # the oracle decides from each state alone
            policy.reset()
            states, images, previous, labels, decisions = [], [], [], [], []
            done, steps, scripted, intended = False, 0, False, None
            while not done:
                time_step = env.time_step
                if noise and intended is not None:
                    # the oracle reads the command the actor meant to send, not the one noise made of
                    # it: reading the executed one, its tests on its own command flicker (grasp_lift
                    # under 2 % noise: 6 of seeds 2000-2039 succeed; reading the intended one, 40)
                    time_step = time_step._replace(observation=dict(time_step.observation, tool_command=intended))
                label = np.clip(env.gym_action(expert(time_step)), -1.0, 1.0)
                decisions.append(expert.last.vector(expert.PHASES, expert.names))
                if steps % segment == 0:
                    scripted = rng.random() < beta
                before = policy.previous.copy()
                command = policy(observation)
                if scripted:
                    command = policy.previous = label
                state = observation["state"] if isinstance(observation, dict) else observation
                states.append(state)
                if kind == "pixels":
                    images.append(observation["pixels"])
                previous.append(before)
                labels.append(label)
                if noise:  # normalised commands: the range is 2 wide
                    intended = env.dm_action(command)
                    command = np.clip(command + rng.normal(0.0, 2.0 * noise, command.shape), -1.0, 1.0)
                observation, _, terminated, truncated, info = env.step(command)
                steps += 1
                done = terminated or truncated
            episodes.append({"seed": int(seed), "success": bool(info["is_success"]), "steps": steps,
                             "state": np.asarray(states, dtype=np.float32),
                             "pixels": np.asarray(images) if kind == "pixels" else None,
                             "clock": np.arange(steps) / limit_steps, "previous_action": np.asarray(previous),
                             "action": np.asarray(labels),
                             "decision": decision_features(np.asarray(decisions), len(expert.PHASES), len(expert.names))})
    finally:
        env.close()
    return episodes


def dagger_round(policy: Cloned, task: str, kind: str, seeds: list[int], beta: float, segment: int, draw_seed: int,
                 workers: int, noise: float = 0.0) -> list[dict]:
    """_dagger_episodes on `seeds`, in `workers` processes (their episodes in seed order)."""
    if workers == 1:
        return _dagger_episodes(policy, task, kind, seeds, beta, segment, draw_seed, noise)
    parts = [list(part) for part in np.array_split(np.asarray(seeds), workers) if len(part)]
    context = multiprocessing.get_context("spawn")
    with concurrent.futures.ProcessPoolExecutor(len(parts), mp_context=context) as pool:
        results = list(pool.map(_dagger_episodes, [policy] * len(parts), [task] * len(parts), [kind] * len(parts),
                                parts, [beta] * len(parts), [segment] * len(parts),
                                [draw_seed + i for i in range(len(parts))], [noise] * len(parts)))
    return [episode for part in results for episode in part]


# -- collecting and evaluating

def collect(root: pathlib.Path, task: str, demos: int, pixels: bool, workers: int) -> bool:
    """The task's scripted demonstrations as a Minari dataset at root/task, unless there already;
    whether it collected them."""
    from viscera import datasets

    if (root / task).exists():
        return False
    root.mkdir(parents=True, exist_ok=True)
    summary = datasets.write(task, root / task, "minari", demonstrator="scripted", seeds=range(demos), pixels=pixels,
                             workers=workers, progress=True)
    print(f"{task}: {summary['episodes']} demonstrations, {summary['successes']} successful, "
          f"{summary['wall_s']:.0f} s", flush=True)
    return True


class RGBOnly:
    """A task's own camera drawing the RGB alone (one draw, bit-identical to its frame's RGB:
    tests/python/test_pixels.py, test_render_rgb_is_the_frames_rgb): a pixel policy reads nothing
    else, so its evaluation does not pay for depth and segmentation, which come back as zeros."""

    def __init__(self, camera):
        self._camera = camera
        self._depth = np.zeros((camera.height, camera.width), np.float32)
        self._segmentation = np.zeros((camera.height, camera.width), np.uint8)

    def render(self, physics) -> dict:
        return {"pixels": self._camera.render_rgb(physics), "depth": self._depth.copy(),
                "segmentation": self._segmentation.copy()}

    def __getattr__(self, name):
        return getattr(self._camera, name)


# the action noise a committed policy must bear: per step, normal, this share of each actuator's range
ACTION_NOISE = 0.02


class Noisy:
    """A dm_env policy whose every command is moved by normal noise of `share` of each actuator's
    range (drawn from `seed`), then clipped to the range: the executed command, which the policy
    does not see (it remembers its own)."""

    def __init__(self, policy, low, high, share: float, seed: int):
        self.policy, self.low, self.high = policy, np.asarray(low), np.asarray(high)
        self.sigma, self.rng = share * (self.high - self.low), np.random.default_rng(seed)

    def __call__(self, time_step) -> np.ndarray:
        command = self.policy(time_step)
        return np.clip(command + self.rng.normal(0.0, self.sigma), self.low, self.high)


def _evaluate_file(path: str, seeds, noise: float = 0.0) -> list[dict]:
    """The policy file's episodes on `seeds`, the file loaded and acting on dm_env time steps as
    `python -m viscera play` runs it; with `noise`, each command moved by that share of its
    actuator's range (Noisy), the noise drawn from the episode's seed."""
    from viscera import policy_file

    policy = policy_file.load(path)
    env = environment(policy.task, policy.pixels is not None)
    policy.check_env(env.dm_env)
    if policy.pixels is not None:
        env.dm_env.task.camera = RGBOnly(env.dm_env.task.camera)
    spec = env.dm_env.action_spec()
    try:
        return [common.policy_episode(env, Noisy(policy, spec.minimum, spec.maximum, noise, int(seed)) if noise else
                                      policy, int(seed)) for seed in seeds]
    finally:
        env.close()


def evaluate(path: pathlib.Path, seeds, workers: int = 1, noise: float = 0.0) -> dict:
    """common.summarise of the policy file's episodes on `seeds`, in `workers` processes (with
    `noise`: _evaluate_file's)."""
    seeds = [int(s) for s in seeds]
    if workers == 1:
        return common.summarise(_evaluate_file(str(path), seeds, noise))
    parts = [list(part) for part in np.array_split(np.asarray(seeds), workers) if len(part)]
    context = multiprocessing.get_context("spawn")
    with concurrent.futures.ProcessPoolExecutor(len(parts), mp_context=context) as pool:
        results = list(pool.map(_evaluate_file, [str(path)] * len(parts), parts, [noise] * len(parts)))
    return common.summarise([episode for part in results for episode in part])


# -- one task, one kind of observation

def run(task: str, kind: str, root: pathlib.Path, demos: int, method: Method, eval_seeds, curve_seeds,
        policy_path: pathlib.Path, workers: int, seed: int = 0, log=print) -> dict:
    """Collect (if missing), clone, DAgger, write the policy file and evaluate it: bc.json's entry."""
    clock = common.Clock()
    collected = collect(root, task, demos, kind == "pixels", workers)
    collection = clock.lap() if collected else None  # else read from an earlier run: its cost unmeasured here
    data = load_demonstrations(root / task, task, pixels=kind == "pixels")
    overlap = sorted(set(data["seeds"]) & set(int(s) for s in eval_seeds))
    if overlap:  # a dataset left from another run can hold any seeds: read, not assumed
        raise SystemExit(f"{root / task}: demonstrations on the evaluation's seeds {overlap[:5]}...")
    # DAgger's episodes on seeds after the demonstrations' (new scenes), all below the evaluation's
    dagger_seeds = list(range(demos, demos + method.dagger_rounds * method.dagger_episodes))
    if dagger_seeds and max(dagger_seeds) >= min(eval_seeds):
        raise SystemExit(f"DAgger's seeds {demos}:{max(dagger_seeds) + 1} reach the evaluation's {min(eval_seeds)}")
    env_steps = data["collected_steps"]
    core_s = collection["cpu_s"] if collection else 0.0
    learner = Learner(data, kind, method, seed)
    frames = data
    stages = {"collect": collection, "train": [], "dagger": [], "curve_eval": []}
    curve = []
    result_record = {}
    with tempfile.TemporaryDirectory() as scratch:
        for round_ in range(method.dagger_rounds + 1):
            if round_:
                rounds = method.dagger_rounds
                beta = method.beta * (rounds - round_) / (rounds - 1) if rounds > 1 else 0.0
                seeds = dagger_seeds[(round_ - 1) * method.dagger_episodes:round_ * method.dagger_episodes]
                clock.lap()
                episodes = dagger_round(learner.policy(), task, kind, seeds, beta, method.segment,
                                        draw_seed=seed * 1000 + round_, workers=workers, noise=method.dagger_noise)
                lap = clock.lap()
                steps = sum(e["steps"] for e in episodes)
                stages["dagger"].append(dict(lap, round=round_, beta=beta, episodes=len(episodes), env_steps=steps,
                                             learner_successes=sum(e["success"] for e in episodes)))
                env_steps += steps
                core_s += lap["cpu_s"]
                frames = aggregate(frames, frames_of(episodes, data["names"], data["action_names"],
                                                     data["time_limit_steps"]))
                log(f"{task} {kind}: DAgger round {round_} (beta {beta:.2f}): {steps} steps, "
                    f"{sum(e['success'] for e in episodes)} of {len(episodes)} episodes succeeded, "
                    f"{lap['wall_s']:.0f} s")
            updates = method.updates if round_ == 0 else method.dagger_updates
            wall, cpu = learner.fit(frames, updates)
            core_s += cpu
            loss = float(np.mean(learner.losses[-100:]))
            stages["train"].append({"round": round_, "updates": updates, "frames": len(frames["action"]),
                                    "wall_s": wall, "cpu_s": cpu, "loss": loss})
            log(f"{task} {kind}: round {round_}: trained on {len(frames['action'])} frames, {updates} updates in "
                f"{wall:.0f} s, loss {loss:.4f}")
            last = round_ == method.dagger_rounds
            training = {"method": dataclasses.asdict(method), "demonstrations": data["episodes"],
                        "demonstration_seeds": [min(data["seeds"]), max(data["seeds"])],
                        "dagger_rounds": round_, "frames": len(frames["action"]), "env_steps": env_steps,
                        "updates": sum(t["updates"] for t in stages["train"]), "final_loss": loss,
                        "versions": common.versions("torch", "minari")}
            path = policy_path if last else pathlib.Path(scratch) / f"round{round_}.npz"
            learner.save(path, task, training=training)
            if last or curve_seeds:
                clock.lap()
                seeds = eval_seeds if last else curve_seeds
                result = evaluate(path, seeds, workers)
                lap = clock.lap()
                (stages.setdefault("eval", []) if last else stages["curve_eval"]).append(dict(lap, round=round_))
                curve.append({"round": round_, "env_steps": env_steps, "core_hours": core_s / 3600.0,
                              "success_rate": result["success_rate"], "mean_return": result["mean_return"],
                              "eval_seeds": [min(seeds), max(seeds)], "episodes": result["episodes"]})
                log(f"{task} {kind}: round {round_}: success {result['success_rate']:.2f} on {len(seeds)} seeds "
                    f"({lap['wall_s']:.0f} s)")
                if last and result["success_rate"] < 0.1:  # no success worth measuring noise against
                    result_record = result
                elif last:
                    result_record = result
                    clock.lap()
                    noisy = evaluate(path, seeds, workers, noise=ACTION_NOISE)
                    lap = clock.lap()
                    result_record["action_noise"] = {"share_of_range": ACTION_NOISE, "wall_s": lap["wall_s"],
                                                     **{k: noisy[k] for k in ("episodes", "success_rate",
                                                                              "success_interval_95")}}
                    log(f"{task} {kind}: with {ACTION_NOISE:.0%} action noise: success {noisy['success_rate']:.2f}")
    train_wall = sum(t["wall_s"] for t in stages["train"])
    train_cpu = sum(t["cpu_s"] for t in stages["train"])
    result_record.update(
        variant="action chunks + DAgger" if method.dagger_rounds else "action chunks",
        chunk=method.chunk, temporal_ensemble_m=method.ensemble_m, dagger_rounds=method.dagger_rounds,
        dagger_episodes_per_round=method.dagger_episodes, dagger_episodes=method.dagger_rounds * method.dagger_episodes,
        demonstrations=data["episodes"], demonstrations_collected=data["total_episodes"],
        demonstration_seeds=[min(data["seeds"]), max(data["seeds"])], demonstration_frames=int(len(data["action"])),
        frames=int(len(frames["action"])), env_steps=env_steps,
        train_wall_s=train_wall, train_cpu_s=train_cpu,
        dagger_wall_s=sum(d["wall_s"] for d in stages["dagger"]), dagger_cpu_s=sum(d["cpu_s"] for d in stages["dagger"]),
        eval_wall_s=stages["eval"][0]["wall_s"], eval_cpu_s=stages["eval"][0]["cpu_s"],
        final_loss=stages["train"][-1]["loss"], updates=sum(t["updates"] for t in stages["train"]),
        batch=method.batch, eval_seeds=[min(eval_seeds), max(eval_seeds)],
        policy_file=str(policy_path), policy_bytes=policy_path.stat().st_size,
        method=dataclasses.asdict(method), stages=stages, curve=curve)
    return result_record


REEVALUATED = ("success_rate", "success_interval_95", "succeeded_seeds", "mean_return", "median_time_to_success_s",
               "median_path_length_m", "median_peak_force_n", "median_safety_cost")


def reevaluate(out: pathlib.Path, tasks, kinds, why: str, workers: int, seeds=None, noise: bool = True) -> int:
    """The committed policies of `tasks` and `kinds` in the record `out`, evaluated again through
    their files on their evaluation seeds (or on `seeds`, which then become theirs): each entry's
    results replaced, the previous ones kept in its `reevaluations` (oldest first) with `why` and
    the date, and the figure redrawn."""
    record = json.loads(out.read_text())
    for task in tasks:
        for kind in kinds:
            entry = record["results"].get(task, {}).get(kind)
            if entry is None:
                continue
            before = {key: entry[key] for key in REEVALUATED if key in entry}
            before["eval_seeds"] = list(entry["eval_seeds"])
            if seeds is not None:
                entry["eval_seeds"], entry["episodes"] = [min(seeds), max(seeds)], len(seeds)
            first, last = entry["eval_seeds"]
            clock = common.Clock()
            result = evaluate(pathlib.Path(entry["policy_file"]), range(first, last + 1), workers)
            lap = clock.lap()
            entry.setdefault("reevaluations", []).append(
                {"why": why, "date": time.strftime("%Y-%m-%d"), "before": before})
            entry.update({key: result[key] for key in REEVALUATED if key in result},
                         eval_wall_s=lap["wall_s"], eval_cpu_s=lap["cpu_s"])
            entry.pop("action_noise", None)
            if noise and entry["success_rate"] >= 0.1:  # what noise takes of a success worth keeping
                clock.lap()
                noisy = evaluate(pathlib.Path(entry["policy_file"]), range(first, last + 1), workers,
                                 noise=ACTION_NOISE)
                entry["action_noise"] = {"share_of_range": ACTION_NOISE, "wall_s": clock.lap()["wall_s"],
                                         **{k: noisy[k] for k in ("episodes", "success_rate", "success_interval_95")}}
            print(f"{task} {kind}: success {before['success_rate']:.2f} before, {entry['success_rate']:.2f} now "
                  f"({len(entry['succeeded_seeds'])} of {last - first + 1} seeds)", flush=True)
            out.write_text(json.dumps(record, indent=1) + "\n")
    figure(record, out.with_suffix(".png"))
    return 0


def figure(record: dict, path: pathlib.Path) -> None:
    """Each policy's success on unseen seeds after each DAgger round, against the environment
    steps (demonstrations and the learner's own episodes) and the CPU core-hours spent so far."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure_, axes = plt.subplots(1, 2, figsize=(10, 3.8), sharey=True)
    for colour, task in enumerate(sorted(record["results"])):
        for kind, entry in sorted(record["results"][task].items()):
            curve = entry["curve"]
            style = dict(marker="o" if kind == "state" else "s", linestyle="-" if kind == "state" else "--",
                         color=f"C{colour}", label=f"{task} ({kind})")
            for axis, key in zip(axes, ("env_steps", "core_hours")):
                axis.plot([c[key] for c in curve], [100.0 * c["success_rate"] for c in curve], **style)
    from matplotlib.ticker import NullFormatter

    for axis, label in zip(axes, ("environment steps (demonstrations + DAgger's episodes)",
                                  "CPU core-hours (training, DAgger, the curve's evaluations)")):
        axis.set_xlabel(label)
        axis.set_xscale("log")
        axis.xaxis.set_minor_formatter(NullFormatter())
        axis.grid(alpha=0.3)
    first, last = record["eval_seeds"]
    axes[0].set_ylabel("success on unseen seeds (%)")
    axes[0].set_ylim(-5, 105)
    axes[1].legend(fontsize=7, loc="center right")
    figure_.suptitle(f"Behaviour cloning: each DAgger round on seeds 2000-2019, the last on {first}-{last}")
    figure_.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    figure_.savefig(path, dpi=110)
    plt.close(figure_)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python python/tools/learning/bc.py", description=__doc__.split("\n\n")[0])
    parser.add_argument("--tasks", nargs="+", choices=TASKS, default=list(TASKS), help="default: all four")
    parser.add_argument("--observations", nargs="+", choices=("state", "pixels"), default=["state", "pixels"],
                        help="what the policies see (default: both, each its own policy)")
    parser.add_argument("--pixel-tasks", nargs="+", choices=TASKS, default=list(PIXEL_TASKS),
                        help=f"the tasks cloned from pixels too (default: {' '.join(PIXEL_TASKS)})")
    parser.add_argument("--demos-state", type=int,
                        help="scripted episodes for the state policies, seeds 0 to N - 1 (default: 500 for "
                             "grasp_lift, 200 for the others)")
    parser.add_argument("--demos-pixels", type=int,
                        help="scripted episodes with pixels for the pixel policies, seeds 0 to N - 1 (default 100)")
    parser.add_argument("--data", type=pathlib.Path, default=pathlib.Path("data") / "demos",
                        help="where the demonstrations' datasets are (written there when missing)")
    parser.add_argument("--eval-seeds", type=common.seed_range, default=range(2000, 2100),
                        help="the unseen seeds A:B the policies are evaluated on (default 2000:2100)")
    parser.add_argument("--curve-seeds", type=common.seed_range, default=None,
                        help="the seeds A:B each earlier DAgger round is evaluated on, for the learning curve "
                             "(default: the evaluation's)")
    parser.add_argument("--no-curve", action="store_true", help="evaluate the last round only")
    parser.add_argument("--chunk", type=int, help="commands predicted per step (default: the method's)")
    parser.add_argument("--ensemble-m", type=float, help="temporal ensembling's m (default: the method's)")
    parser.add_argument("--updates", type=int, help="Adam steps on the demonstrations (default: the method's)")
    parser.add_argument("--dagger-rounds", type=int, help="DAgger rounds (default: the method's)")
    parser.add_argument("--dagger-episodes", type=int, help="learner episodes per DAgger round")
    parser.add_argument("--dagger-updates", type=int, help="Adam steps after each DAgger round")
    parser.add_argument("--dagger-noise", type=common.fraction,
                        help="DAgger's executed commands moved by normal noise of this share of each actuator's "
                             "range, the oracle labelling the states it leads to (DART; default: the method's, 0)")
    parser.add_argument("--previous-noise", type=common.fraction,
                        help="training moves the previous-command input by normal noise of this size, in "
                             "normalised action units (default: the method's, 0)")
    parser.add_argument("--hidden", type=int, nargs="+", help="the MLP's hidden layer sizes")
    parser.add_argument("--loss", choices=("l1", "mse"), help="the training loss (default: l1, ACT's)")
    parser.add_argument("--memory", action="store_true",
                        help="the network also says what the oracle is doing (phase, lead tool, aims) and reads "
                             "what it said at the step before (Method.memory)")
    parser.add_argument("--workers", type=int, default=1, help="processes collecting, rolling out and evaluating")
    parser.add_argument("--policies", type=pathlib.Path, default=POLICIES,
                        help=f"where the policy files go, TASK_KIND.npz (default {POLICIES})")
    parser.add_argument("--out", type=pathlib.Path, default=OUT, help=f"the results JSON (default {OUT})")
    parser.add_argument("--no-noise", action="store_true",
                        help="with --reevaluate: leave out the run under action noise")
    parser.add_argument("--reevaluate", metavar="WHY",
                        help="train nothing: evaluate the committed policy files of --tasks and --observations "
                             "again on their evaluation seeds after a change of the tasks (WHY names it), keeping "
                             "the previous result beside the new one")
    args = parser.parse_args(argv)
    if args.reevaluate:
        given_seeds = "--eval-seeds" in (argv if argv is not None else sys.argv)
        return reevaluate(args.out, args.tasks, args.observations, args.reevaluate, args.workers,
                          list(args.eval_seeds) if given_seeds else None, noise=not args.no_noise)
    given = {"state": args.demos_state, "pixels": args.demos_pixels}
    demos = {kind: {task: given[kind] or DEMOS[kind][task] for task in TASKS} for kind in DEMOS}
    most = max(count for kind in args.observations for count in demos[kind].values())
    if min(args.eval_seeds) < most:
        parser.error(f"--eval-seeds {min(args.eval_seeds)}:{max(args.eval_seeds) + 1} overlaps the demonstrations' "
                     f"seeds 0:{most}")
    overrides = {key: value for key, value in (
        ("chunk", args.chunk), ("ensemble_m", args.ensemble_m), ("updates", args.updates),
        ("dagger_rounds", args.dagger_rounds), ("dagger_episodes", args.dagger_episodes),
        ("dagger_updates", args.dagger_updates), ("dagger_noise", args.dagger_noise),
        ("previous_noise", args.previous_noise),
        ("hidden", tuple(args.hidden) if args.hidden else None),
        ("loss", args.loss), ("memory", True if args.memory else None)) if value is not None}
    curve_seeds = None if args.no_curve else list(args.curve_seeds or args.eval_seeds)

    record = json.loads(args.out.read_text()) if args.out.exists() else {"results": {}}
    record.update(eval_seeds=[min(args.eval_seeds), max(args.eval_seeds)], image_size=list(IMAGE_SIZE),
                  versions=common.versions("torch", "minari"))
    record.pop("updates", None)
    record.pop("batch", None)
    for task in args.tasks:
        for kind in args.observations:
            if kind == "pixels" and task not in args.pixel_tasks:
                continue
            method = dataclasses.replace(METHOD[kind], **{"dagger_rounds": DAGGER_ROUNDS[task], **overrides})
            result = run(task, kind, args.data / kind, demos[kind][task], method, list(args.eval_seeds), curve_seeds,
                         args.policies / f"{task}_{kind}.npz", args.workers, log=lambda text: print(text, flush=True))
            record["results"].setdefault(task, {})[kind] = result
            print(f"{task} {kind}: success {result['success_rate']:.2f}, policy file "
                  f"{result['policy_bytes'] / 1024:.0f} kB", flush=True)
            args.out.parent.mkdir(parents=True, exist_ok=True)
            args.out.write_text(json.dumps(record, indent=1) + "\n")
            figure(record, args.out.with_suffix(".png"))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
