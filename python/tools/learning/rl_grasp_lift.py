"""Reinforcement learning on grasp_lift with stable-baselines3's PPO, within a CPU budget: a learning
curve of success on unseen seeds against environment steps and CPU core-hours, written to
docs/learning/rl_grasp_lift.json (and its figure, docs/learning/rl_grasp_lift.png).

    pip install ".[learning]"
    python python/tools/learning/rl_grasp_lift.py --budget-core-hours 1.0 [--envs 4] \
        [--eval-every 100000] [--eval-seeds 2000:2020] [--final-seeds 2000:2050] [--out docs/learning/rl_grasp_lift.json]

- The environment: gymnasium's viscera/GraspLift-v0 (viscera.scale.gym_env.TaskEnv), flat state
  observations (the task's own: tool joints and forces, the grasp, the intestine's axis points,
  gravity, the band), actions normalised to [-1, 1], the task's shaped reward.
- Training episodes: stable-baselines3 seeds the vector environment from PPO's seed (0), so
  environment i starts on the task's seed i and draws its following episodes from that seed's
  RandomState; the curve's seeds (2000-2019) and the final 50 (2000-2049) are the first episodes
  of other seeds, which no training episode is.
- The budget is CPU time: the process's own (learner and environments run in this one process,
  PyTorch on one thread), so a core-hour is an hour of one core. Training stops at the first
  update after it is spent.
- The JSON is rewritten at each evaluation, so a run cut short still leaves its curve.
"""

from __future__ import annotations

import argparse
import json
import pathlib
import sys
import time

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import common  # noqa: E402  (python/tools/learning/common.py)

OUT = pathlib.Path("docs") / "learning" / "rl_grasp_lift.json"
TASK = "grasp_lift"


def evaluate(model, normalizer, seeds: list[int]) -> dict:
    """The deterministic policy on each seed: success, return, the assessment's scores."""
    from viscera.scale.gym_env import TaskEnv

    env = TaskEnv(TASK)

    def act(observation):
        observation = normalizer.normalize_obs(observation[None])[0] if normalizer is not None else observation
        return model.predict(observation, deterministic=True)[0]

    try:
        return common.evaluate_policy(env, act, seeds)
    finally:
        env.close()


def references(seeds: list[int]) -> dict:
    """The scripted policy's and uniform random actions' success and return on `seeds`: what the
    curve's returns compare with (the script ends its episodes early, on success)."""
    import viscera.tasks
    from viscera.scale.gym_env import TaskEnv

    env = TaskEnv(TASK)

    class Scripted:
        def reset(self):
            self.policy = viscera.tasks.scripted_policy(env.dm_env)

        def __call__(self, observation):
            return np.clip(env.gym_action(self.policy(env.time_step)), -1.0, 1.0)

    rng = np.random.default_rng(0)
    found = {}
    for name, act in (("scripted", Scripted()), ("random", lambda o: rng.uniform(-1.0, 1.0, env.action_space.shape))):
        result = common.evaluate_policy(env, act, seeds)
        found[name] = {"success_rate": result["success_rate"], "mean_return": result["mean_return"]}
    env.close()
    return found


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python python/tools/learning/rl_grasp_lift.py", description=__doc__.split("\n\n")[0])
    parser.add_argument("--budget-core-hours", type=float, default=1.0,
                        help="CPU time to train for, evaluations included (default 1.0)")
    parser.add_argument("--envs", type=int, default=4, help="environments stepped in lockstep in this process")
    parser.add_argument("--eval-every", type=int, default=100_000, help="environment steps between evaluations")
    parser.add_argument("--eval-seeds", type=common.seed_range, default=range(2000, 2020),
                        help="the learning curve's unseen seeds A:B (default 2000:2020)")
    parser.add_argument("--final-seeds", type=common.seed_range, default=range(2000, 2050),
                        help="the trained policy's unseen seeds A:B (default 2000:2050)")
    parser.add_argument("--out", type=pathlib.Path, default=OUT, help=f"the results JSON (default {OUT})")
    args = parser.parse_args(argv)

    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.callbacks import BaseCallback
    from stable_baselines3.common.vec_env import DummyVecEnv, VecMonitor, VecNormalize

    from viscera.scale.gym_env import TaskEnv

    torch.set_num_threads(1)
    budget_s = args.budget_core_hours * 3600.0
    cpu_start = time.process_time()

    # seeded at the first reset (from PPO's seed): environment i from task seed i
    venv = VecNormalize(VecMonitor(DummyVecEnv([lambda: TaskEnv(TASK)] * args.envs)),
                        norm_obs=True, norm_reward=False, clip_obs=10.0)
    hyper = dict(n_steps=1024, batch_size=256, n_epochs=10, learning_rate=3e-4, gamma=0.99, gae_lambda=0.95,
                 clip_range=0.2, ent_coef=0.0, policy_kwargs=dict(net_arch=[256, 256], log_std_init=-0.5))
    model = PPO("MlpPolicy", venv, seed=0, verbose=0, device="cpu", **hyper)
    curve: list[dict] = []
    record = {"task": TASK, "algorithm": "PPO (stable-baselines3)", "hyperparameters": hyper,
              "envs": args.envs, "budget_core_hours": args.budget_core_hours,
              "train_seeds": f"environment i starts on task seed i (0 to {args.envs - 1}), then draws from its RandomState",
              "eval_seeds": [min(args.eval_seeds), max(args.eval_seeds)],
              "final_seeds": [min(args.final_seeds), max(args.final_seeds)], "curve": curve,
              "versions": common.versions("stable_baselines3", "torch")}

    record["references_on_eval_seeds"] = references(list(args.eval_seeds))
    record["references_note"] = "the scripted policy and uniform random actions on the curve's seeds, the same episode returns"

    def write():
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(record, indent=1) + "\n")

    class Curve(BaseCallback):
        """Evaluates on the unseen seeds every `eval_every` steps; stops once the budget is spent."""

        def __init__(self):
            super().__init__()
            self.next_eval = 0

        def _on_step(self) -> bool:
            return time.process_time() - cpu_start <= budget_s

        def _on_rollout_end(self) -> None:
            steps = self.num_timesteps
            if steps >= self.next_eval:
                self.next_eval = steps + args.eval_every
                cpu_s = time.process_time() - cpu_start  # evaluations are counted in the budget
                result = evaluate(self.model, venv, list(args.eval_seeds))
                curve.append({"env_steps": int(steps), "core_hours": cpu_s / 3600.0,
                              "success_rate": result["success_rate"], "mean_return": result["mean_return"]})
                print(f"{steps:>9} steps  {cpu_s / 3600:.3f} core-h  success {result['success_rate']:.2f}"
                      f"  return {result['mean_return']:.1f}", flush=True)
                write()

    wall_start = time.perf_counter()
    model.learn(total_timesteps=10 ** 9, callback=Curve())
    record["train_env_steps"] = int(model.num_timesteps)
    record["train_core_hours"] = (time.process_time() - cpu_start) / 3600.0
    record["train_wall_s"] = time.perf_counter() - wall_start
    model.save(args.out.with_suffix(".zip"))
    venv.save(str(args.out.with_suffix(".normalizer.pkl")))
    final = evaluate(model, venv, list(args.final_seeds))
    record["final"] = final
    write()
    common.curve_figure(record, args.out.with_suffix(".png"))
    print(f"final: success {final['success_rate']:.2f} on {len(args.final_seeds)} unseen seeds")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
