"""Episodes into a Minari dataset, written by Minari's own writer (create_dataset_from_buffers,
then update_dataset_from_buffer per episode): gymnasium's offline-RL format.

The dataset's id is `viscera/<task>/<demonstrator>-v0` under a datasets root (MINARI_DATASETS_PATH):

    MINARI_DATASETS_PATH=OUT python -c "import minari; d = minari.load_dataset('viscera/grasp_lift/scripted-v0')"

- observations: gymnasium's TaskEnv(task, flatten=True[, pixels=True]): the flat float64 state
  vector, or with pixels a Dict of it (`state`) and the camera's `pixels`, `depth` and
  `segmentation`, stored raw (lossless; Minari's JPEG encoding is off);
- actions: normalised to [-1, 1]; rewards, terminations, truncations as the environment gives;
- infos: `is_success`; `privileged`, a dict of the privileged state (viscera.datasets.episodes);
  `demonstrator_action`, what the demonstrator commanded (the action unless noise was injected;
  infos follow each step, so row t + 1 labels action t and the reset's row 0 is zeros);
- each episode's seed is the task's seed; the environment spec recovers the environment
  (`dataset.recover_environment()`, after `import viscera`);
- with the scripted demonstrator, infos `oracle`: `phase`, `lead`, `aims`, what the oracle said it
  was doing (viscera.datasets.episodes.ORACLE_LABELS; as demonstrator_action, row t + 1 labels
  action t, and the reset's row 0 is -1, -1 and zeros).
"""

from __future__ import annotations

import os
import pathlib
import warnings

import numpy as np

from viscera.datasets.episodes import Episode


def dataset_id(task: str, demonstrator: str) -> str:
    return f"viscera/{task}/{demonstrator.replace(':', '-')}-v0"


def _buffer(episode: Episode):
    from minari.data_collector import EpisodeBuffer

    if episode.images:
        observations = {"state": episode.state, **episode.images}
    else:
        observations = episode.state
    infos = {"is_success": episode.is_success, "privileged": dict(episode.privileged),
             "demonstrator_action": np.concatenate([np.zeros_like(episode.action[:1]), episode.demonstrator_action])}
    if episode.oracle:
        infos["oracle"] = {name: np.concatenate([np.zeros_like(values[:1]) if name == "aims" else np.full_like(values[:1], -1), values])
                           for name, values in episode.oracle.items()}
    return EpisodeBuffer(seed=episode.seed, observations=observations, actions=episode.action,
                         rewards=episode.reward, terminations=episode.terminated, truncations=episode.truncated,
                         infos=infos)


class MinariWriter:
    """Writes episodes, one at a time, into a new datasets root `root` (a staging folder)."""

    def __init__(self, root: pathlib.Path, env, spec, task: str, demonstrator: str, description: str):
        self.root, self.env, self.spec, self.description = pathlib.Path(root), env, spec, description
        self.id, self.demonstrator = dataset_id(task, demonstrator), demonstrator
        self.dataset = None

    def add(self, episode: Episode) -> None:
        import minari

        previous = os.environ.get("MINARI_DATASETS_PATH")
        # where Minari's writer puts the dataset: absolute, as Minari joins a relative one to itself
        # (its second episode's size was looked up under data/x/.../data/x/..., and the write failed)
        os.environ["MINARI_DATASETS_PATH"] = str(self.root.resolve())
        try:
            if self.dataset is None:
                with warnings.catch_warnings():  # a dataset made on a user's machine has no permalink or e-mail
                    warnings.filterwarnings("ignore", message="`(code_permalink|author_email)` is set to None")
                    self.dataset = minari.create_dataset_from_buffers(
                        self.id, [_buffer(episode)], env=self.spec, eval_env=self.spec, author="viscera",
                        algorithm_name=f"viscera {self.demonstrator}", description=self.description,
                        observation_space=self.env.observation_space, action_space=self.env.action_space,
                        jpeg_encoding=False)
            else:
                self.dataset.update_dataset_from_buffer([_buffer(episode)])
        finally:
            if previous is None:
                os.environ.pop("MINARI_DATASETS_PATH", None)
            else:
                os.environ["MINARI_DATASETS_PATH"] = previous

    def finish(self) -> None:
        """Nothing left to write: each episode was written as it came."""

    def abort(self) -> None:
        self.dataset = None


def load(root: str | os.PathLike, task: str, demonstrator: str):
    """The Minari dataset a writer made under `root`, by Minari's own loader."""
    import minari

    return minari.MinariDataset(pathlib.Path(root) / dataset_id(task, demonstrator) / "data")
