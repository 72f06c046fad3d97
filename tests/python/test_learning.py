"""The learning baselines' short version: behaviour cloning from a few scripted demonstrations,
read back from a Minari dataset, does better than random actions on a fixed seed
(python/tools/learning/bc.py; the full results, on 50 unseen seeds, are on docs/learning.md)."""

import numpy as np

from viscera import datasets
from viscera.datasets import episodes
from viscera.scale.gym_env import TaskEnv


def test_behaviour_cloning_beats_random_actions(tmp_path):
    from learning import bc, common

    datasets.write("grasp_lift", tmp_path / "demos", "minari", seeds=range(6), workers=2)
    data = bc.load_demonstrations(tmp_path / "demos", "grasp_lift", pixels=False)
    assert data["episodes"] >= 5  # the script succeeds on nearly every seed
    policy, *_ = bc.train(data, "state", updates=1500)
    env = TaskEnv(**episodes.env_kwargs("grasp_lift", "abdomen", False, (84, 84)))
    rng = np.random.default_rng(0)
    seed = 0  # the first demonstration's episode: six demonstrations teach the approach, not yet the grasp
    cloned = common.episode(env, policy, seed)
    uniform = common.episode(env, lambda observation: rng.uniform(-1.0, 1.0, env.action_space.shape), seed)
    env.close()
    # the reward's potential, 0.5 exp(-distance / 5 cm) while the tip nears the band: the cloned
    # policy brings the tip to the band and keeps it there (a return of the potential gained, less
    # the episode's time cost of 1), random actions seldom come near
    assert cloned["return"] > uniform["return"] + 0.2, (cloned, uniform)
