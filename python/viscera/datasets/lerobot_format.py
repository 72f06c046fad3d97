"""Episodes into a LeRobot dataset (format v3.0), written by LeRobot's own writer
(LeRobotDataset.create, add_frame, save_episode, finalize): the format of the surgical-robot
datasets of the field (Open-H-Embodiment, SutureBot).

    from lerobot.datasets.lerobot_dataset import LeRobotDataset
    dataset = LeRobotDataset("viscera/grasp_lift-scripted", root=OUT, video_backend="pyav")

One frame per control tick (LeRobot keeps no frame for the observation after the last action):
- `observation.state`: float32, the task's flat state vector (gymnasium's TaskEnv observation;
  the feature's names give each entry, e.g. `intestine_axis[0]`);
- with pixels, `observation.images.laparoscope`: the laparoscope's RGB as video (LeRobot's
  default AV1 codec: lossy), `observation.depth` (float32, m) and `observation.segmentation`
  (uint8 labels, viscera.pixels.LABELS), both lossless;
- `action`: float32, normalised to [-1, 1] (gymnasium's action, as taken; names: the actuators);
- `demonstrator_action`: what the demonstrator commanded (the action, unless noise was injected);
- `next.reward` (float32), `next.done`, `next.success` (bool): after the frame's action;
- `seed`: the task's seed, the same on every frame of an episode;
- `privileged.<name>`: the privileged state (viscera.datasets.episodes.PRIVILEGED), float32;
- with the scripted demonstrator (an oracle, viscera.tasks.oracle), `oracle.phase` and
  `oracle.lead` (int64) and `oracle.aims` (float32, m, per tool x y z): what it said
  it was doing at the frame's action (viscera.datasets.episodes.ORACLE_LABELS).
The task string is the task's success criterion. LeRobot stores floats as float32 (its loader
returns them so), so the float64 simulation values are rounded once, on writing.
"""

from __future__ import annotations

import os
import pathlib

import numpy as np

from viscera.datasets.episodes import PRIVILEGED, Episode

CAMERA_KEY = "observation.images.laparoscope"


def repo_id(task: str, demonstrator: str) -> str:
    return f"viscera/{task}-{demonstrator.replace(':', '-')}"


def features(episode: Episode) -> dict:
    """LeRobot's feature description of an episode's frames."""
    found = {
        "observation.state": {"dtype": "float32", "shape": (episode.state.shape[1],), "names": episode.state_names},
        "action": {"dtype": "float32", "shape": (episode.action.shape[1],), "names": episode.action_names},
        "demonstrator_action": {"dtype": "float32", "shape": (episode.action.shape[1],), "names": episode.action_names},
        "next.reward": {"dtype": "float32", "shape": (1,), "names": None},
        "next.done": {"dtype": "bool", "shape": (1,), "names": None},
        "next.success": {"dtype": "bool", "shape": (1,), "names": None},
        "seed": {"dtype": "int64", "shape": (1,), "names": None},
    }
    if episode.images:
        found[CAMERA_KEY] = {"dtype": "video", "shape": episode.images["pixels"].shape[1:],
                             "names": ["height", "width", "channels"]}
        found["observation.depth"] = {"dtype": "float32", "shape": episode.images["depth"].shape[1:],
                                      "names": ["height", "width"]}
        found["observation.segmentation"] = {"dtype": "uint8", "shape": episode.images["segmentation"].shape[1:],
                                             "names": ["height", "width"]}
    for name, values in episode.oracle.items():
        if name == "aims":
            tools = [n.rsplit("_", 1)[0] for n in episode.action_names]
            tools = list(dict.fromkeys(tools))
            found["oracle.aims"] = {"dtype": "float32", "shape": (values.shape[1] * 3,),
                                    "names": [f"{tool}.{c}" for tool in tools for c in "xyz"]}
        else:
            found[f"oracle.{name}"] = {"dtype": "int64", "shape": (1,), "names": None}
    for name in PRIVILEGED:
        shape = episode.privileged[name].shape[1:]
        if int(np.prod(shape)) > 0:  # a task without a grasper has no grasp state
            found[f"privileged.{name}"] = {"dtype": "float32", "shape": shape, "names": None}
    return found


def frames(episode: Episode, criterion: str):
    """The episode's LeRobot frames, one per action."""
    for t in range(episode.steps):
        frame = {"observation.state": episode.state[t].astype(np.float32),
                 "action": episode.action[t].astype(np.float32),
                 "demonstrator_action": episode.demonstrator_action[t].astype(np.float32),
                 "next.reward": np.array([episode.reward[t]], dtype=np.float32),
                 "next.done": np.array([episode.terminated[t] or episode.truncated[t]]),
                 "next.success": np.array([episode.is_success[t + 1]]),
                 "seed": np.array([episode.seed], dtype=np.int64), "task": criterion}
        if episode.images:
            frame[CAMERA_KEY] = episode.images["pixels"][t]
            frame["observation.depth"] = episode.images["depth"][t].astype(np.float32)
            frame["observation.segmentation"] = episode.images["segmentation"][t].astype(np.uint8)
        for name, values in episode.oracle.items():
            frame[f"oracle.{name}"] = values[t].ravel().astype(np.float32) if name == "aims" else \
                np.array([values[t]], dtype=np.int64)
        for name, values in episode.privileged.items():
            if values[t].size:
                frame[f"privileged.{name}"] = values[t].astype(np.float32)
        yield frame


class LeRobotWriter:
    """Writes episodes, one at a time, into a new LeRobot dataset at `root` (a staging folder)."""

    def __init__(self, root: pathlib.Path, env, spec, task: str, demonstrator: str, description: str):
        self.root, self.id = pathlib.Path(root), repo_id(task, demonstrator)
        self.dataset = None

    def add(self, episode: Episode) -> None:
        from lerobot.datasets.lerobot_dataset import LeRobotDataset

        from viscera.tasks import base

        if self.dataset is None:
            self.dataset = LeRobotDataset.create(self.id, fps=episode.fps,
                                                 features=features(episode), root=self.root, robot_type="viscera",
                                                 use_videos=True)
        criterion = base.SUITE[episode.task].CRITERION
        for frame in frames(episode, criterion):
            self.dataset.add_frame(frame)
        self.dataset.save_episode()

    def finish(self) -> None:
        if self.dataset is not None:
            self.dataset.finalize()

    def abort(self) -> None:
        """Close LeRobot's writers before the staging folder goes: its buffered metadata writer
        would otherwise recreate files there when it is collected."""
        if self.dataset is not None:
            dataset, self.dataset = self.dataset, None
            try:
                dataset.finalize()
            except Exception:  # noqa: BLE001  an abandoned dataset: what it writes is removed anyway
                pass


def load(root: str | os.PathLike, task: str, demonstrator: str):
    """The LeRobot dataset a writer made at `root`, by LeRobot's own loader (videos decoded by PyAV,
    which needs no system FFmpeg)."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    return LeRobotDataset(repo_id(task, demonstrator), root=root, video_backend="pyav")
