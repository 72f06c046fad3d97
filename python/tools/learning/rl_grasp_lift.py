"""Reinforcement learning on grasp_lift with stable-baselines3's PPO, within a CPU budget, started
from the scripted demonstrations: a learning curve of success on unseen seeds against environment
steps and CPU core-hours, written to docs/learning/rl_grasp_lift.json (and its figure,
docs/learning/rl_grasp_lift.png).

    pip install ".[learning]"
    python python/tools/learning/rl_grasp_lift.py --budget-core-hours 2.0 [--envs 4] \
        [--start residual|demos|scratch] [--base docs/learning/policies/grasp_lift_state.npz] \
        [--residual-scale 0.1] [--learning-rate R] [--demos 500] [--data data/demos] [--pretrain-updates 20000] [--critic-warmup 10] \
        [--eval-every 100000] [--eval-seeds 2000:2020] [--final-seeds 2000:2050] [--out docs/learning/rl_grasp_lift.json]

- The environment: gymnasium's viscera/GraspLift-v0 (viscera.scale.gym_env.TaskEnv), flat state
  observations (the task's own: tool joints and forces, the grasp, the intestine's axis points,
  gravity, the band), actions normalised to [-1, 1], the task's dense reward (its contract:
  success is the best return). The policy also sees its own memory, as the cloned policies do
  (bc.py): its clock (control steps taken over the episode's) and its previous action.
- The start (the issue allows demonstrations), `--start`:
  - `residual` (the default): residual policy learning (Silver et al. 2018; Johannink et al., ICRA
    2019). The action is the cloned policy's command (bc.py's policy file, `--base`) plus up to
    `--residual-scale` of PPO's correction; PPO sees the state, the clock and the base's command,
    and its correction starts at zero, so training starts from the cloned policy. The base's
    training CPU time (docs/learning/bc.json) is counted in the budget and its demonstrations' steps
    in the curve's environment steps.
  - `demos`: `--demos` scripted episodes on seeds 0 to N - 1, collected here unless already at
    DATA/state/grasp_lift (their CPU time is then counted in the budget), set the observation
    normalisation (then fixed), and PPO's actor's mean is trained on them (`--pretrain-updates`
    Adam steps, L1, as bc.py) with the clock and its previous action among its inputs.
  - `scratch`: PPO alone.
  Started either way, PPO trains the critic alone for `--critic-warmup` rollouts, so that the first
  policy updates follow a value that knows the task, then both.
- Training episodes: stable-baselines3 seeds the vector environment from PPO's seed (0), so
  environment i starts on the task's seed i and draws its following episodes from that seed's
  RandomState; the curve's seeds (2000-2019) and the final 50 (2000-2049) are the first episodes
  of other seeds, which no training episode is.
- The budget is CPU time: the process's own and its finished children's (learner and environments
  run in this one process, PyTorch on one thread), so a core-hour is an hour of one core. Training
  stops at the first update after it is spent.
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
import bc  # noqa: E402  (python/tools/learning/bc.py: the demonstrations)
import common  # noqa: E402  (python/tools/learning/common.py)

OUT = pathlib.Path("docs") / "learning" / "rl_grasp_lift.json"
BASE = pathlib.Path("docs") / "learning" / "policies" / "grasp_lift_state.npz"
TASK = "grasp_lift"
POLICY = pathlib.Path("docs") / "learning" / "policies" / "grasp_lift_rl.npz"
GAMMA = 0.995  # PPO's discount, and the shaping's gamma


def with_memory(env, base_path: pathlib.Path | None = None, scale: float = 0.1, gamma: float | None = None):
    """`env` (a TaskEnv) made the learner's environment.

    - Without a base: its observation also holds the clock (control steps taken over the
      episode's) and the previous action (zeros at the start), as bc.py's policies have.
    - With a base policy file: residual policy learning (Silver et al. 2018, Johannink et al.,
      ICRA 2019). The observation is what the policy file's residual reads (LearnedPolicy.
      correction_inputs: the state as the base's network reads it, normalised with its floors and
      clipped, the base's clock and the base's command), so the trained correction is written into
      the file as it is. The action is the base's command plus `scale` times the correction
      (LearnedPolicy.corrected: the base's held actuators stay held), and the base takes the
      executed command as its previous one.
    - With `gamma`: the task's dense reward, Phi(s') - Phi(s) - c (+ the bonus on success), made
      the potential-based form for a learner discounting by gamma (Ng, Harada and Russell 1999):
      gamma Phi(s') - Phi(s) - c, by adding (gamma - 1) Phi(s') on every step the task does not end
      (success or failure pays its last Phi(s') whole; PPO bootstraps a time limit's last step)."""
    import gymnasium

    from viscera import policy_file

    class WithMemory(gymnasium.Wrapper):
        def __init__(self, env):
            super().__init__(env)
            self.base = None if base_path is None else policy_file.load(base_path)
            self.limit_steps = int(round(env.dm_env.time_limit_s / env.dm_env.control_timestep()))
            actions = env.action_space.shape[0]
            if self.base is not None:
                self.base.check_env(env.dm_env)
                size = sum(n for _, n in self.base.state_entries) + 1 + actions
            else:
                size = env.observation_space.shape[0] + 1 + actions
            self.observation_space = gymnasium.spaces.Box(-np.inf, np.inf, (size,), np.float64)

        @property
        def dm_env(self):
            return self.env.dm_env

        def _observed(self, observation):
            if self.base is None:
                return np.concatenate([observation, [self.steps / self.limit_steps], self.memory])
            state = self.base.state_of(self.env.time_step.observation)
            clock = self.base.clock
            self.memory = self.base.act(state)  # the base's command
            return self.base.correction_inputs(state, clock, self.memory)

        def reset(self, **kwargs):
            observation, info = self.env.reset(**kwargs)
            self.steps, self.memory = 0, np.zeros(self.env.action_space.shape)
            if self.base is not None:
                self.base.reset()
            return self._observed(observation), info

        def step(self, action):
            action = np.clip(np.asarray(action, dtype=float), -1.0, 1.0)
            if self.base is not None:
                action = self.base.corrected(self.memory, action, scale)
            observation, reward, terminated, truncated, info = self.env.step(action)
            self.steps += 1
            if self.base is not None:
                self.base.executed(action)
            else:
                self.memory = action
            if gamma is not None and not terminated:  # a time limit's last step is bootstrapped: shaped too
                reward += (gamma - 1.0) * self.env.dm_env.task.last_potential
            return self._observed(observation), reward, terminated, truncated, info

    return WithMemory(env)


def export(model, base_path: pathlib.Path, scale: float, path: pathlib.Path, training: dict):
    """The residual PPO's deterministic policy written as a policy file: the base's file with an
    `architecture.residual`, the actor's layers (ReLU) as its dense layers. Returns it loaded."""
    import copy

    import torch

    from viscera import policy_file

    base = policy_file.load(base_path)
    linears = [m for m in model.policy.mlp_extractor.policy_net if isinstance(m, torch.nn.Linear)]
    linears.append(model.policy.action_net)
    weights = dict(base.weights)
    layers = []
    for i, linear in enumerate(linears):
        weights[f"residual{i}.weight"] = linear.weight.detach().double().numpy()
        weights[f"residual{i}.bias"] = linear.bias.detach().double().numpy()
        layers.append({"kind": "dense", "weight": f"residual{i}.weight", "bias": f"residual{i}.bias",
                       "activation": "relu" if i < len(linears) - 1 else "none"})
    architecture = copy.deepcopy(base.meta["architecture"])
    architecture["residual"] = {"inputs": list(policy_file.RESIDUAL_INPUTS), "layers": layers, "scale": scale}
    fields = base.fields
    fields = {k: v for k, v in fields.items() if k not in ("training", "architecture")}
    return policy_file.save(path, weights=weights, architecture=architecture, training=training, **fields)


def demonstration_inputs(frames: dict) -> tuple[np.ndarray, np.ndarray]:
    """bc.load_demonstrations' frames as (observations with memory, the script's actions)."""
    inputs = np.concatenate([frames["state"], frames["clock"][:, None], frames["previous_action"]], axis=1)
    return inputs.astype(np.float64), np.clip(frames["action"], -1.0, 1.0).astype(np.float32)


def pretrain(model, normalizer, frames: dict, updates: int, seed: int = 0) -> dict:
    """The normalisation's statistics from the demonstrations (then fixed) and the actor's mean
    trained on their actions (Adam, L1, cosine rate 1e-3 to 1e-5, batches of 256); its last loss."""
    import torch

    observations, actions = demonstration_inputs(frames)
    normalizer.obs_rms.mean = observations.mean(axis=0)
    normalizer.obs_rms.var = observations.var(axis=0) + 1e-8
    normalizer.obs_rms.count = float(len(observations))
    normalizer.training = False  # the statistics the actor was trained with stay
    inputs = torch.as_tensor(normalizer.normalize_obs(observations), dtype=torch.float32)
    targets = torch.as_tensor(actions)
    policy = model.policy
    actor = list(policy.mlp_extractor.policy_net.parameters()) + list(policy.action_net.parameters())
    optimiser = torch.optim.Adam(actor, lr=1e-3)
    generator = torch.Generator().manual_seed(seed)
    losses = []
    policy.train()
    for update in range(updates):
        for group in optimiser.param_groups:
            group["lr"] = 1e-5 + 0.5 * (1e-3 - 1e-5) * (1.0 + np.cos(np.pi * update / updates))
        index = torch.randint(len(inputs), (256,), generator=generator)
        loss = (policy.get_distribution(inputs[index]).distribution.mean - targets[index]).abs().mean()
        optimiser.zero_grad()
        loss.backward()
        optimiser.step()
        losses.append(float(loss.detach()))
    policy.set_training_mode(False)
    return {"updates": updates, "final_loss": float(np.mean(losses[-100:])) if losses else None,
            "frames": int(len(inputs))}


def evaluate(model, normalizer, make_env, seeds: list[int]) -> dict:
    """The deterministic policy on each seed of `make_env()`: success, return, the assessment's scores."""
    env = make_env()

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


def check_export(trained, model, make_env, scale: float, steps: int = 30) -> None:
    """That the written policy file commands what the trained model does through its wrapper, on
    the first steps of an episode (float64 NumPy against torch's float32)."""
    env = make_env()
    observation, _ = env.reset(seed=0)
    trained.reset()
    worst = 0.0
    for _ in range(steps):
        action = model.predict(observation, deterministic=True)[0]
        wrapper = env.base.corrected(env.memory, np.clip(action, -1.0, 1.0), scale)
        mine = trained.act(trained.state_of(env.env.time_step.observation))
        worst = max(worst, float(np.max(np.abs(mine - wrapper))))
        observation, *_ = env.step(action)
    env.close()
    if worst > 1e-3:
        raise RuntimeError(f"{trained.path}: the file's commands differ from the trained model's by {worst:.2g}")


def earlier_attempts(path: pathlib.Path) -> list[dict]:
    """The runs a record at `path` holds (its attempts, then its own run), kept in the new record's
    `attempts` (drawn thin and dashed in the figure)."""
    if not path.exists():
        return []
    old = json.loads(path.read_text())
    start = old["start"]
    hyper = old["hyperparameters"]
    described = {"residual": f"residual on the cloned policy, corrections up to {start.get('residual_scale')}",
                 "demos": f"actor pretrained on {start.get('demonstrations')} demonstrations",
                 "scratch": "from scratch (PPO alone)"}[start["kind"]]
    described += f", rate {hyper['learning_rate']:g}, {hyper['n_epochs']} epochs (viscera {old['versions'].get('viscera', '?')})"
    own = {"start": described, "hyperparameters": hyper, "start_details": start, "curve": old["curve"],
           "stopped": old.get("stopped", "at its budget"), "final": old.get("final"), "final_seeds": old.get("final_seeds")}
    return old.get("attempts", []) + [own]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python python/tools/learning/rl_grasp_lift.py", description=__doc__.split("\n\n")[0])
    parser.add_argument("--budget-core-hours", type=float, default=1.0,
                        help="CPU time to train for, evaluations included (default 1.0)")
    parser.add_argument("--envs", type=int, default=4, help="environments stepped in lockstep in this process")
    parser.add_argument("--start", choices=("residual", "demos", "scratch"), default="residual",
                        help="residual: PPO learns a correction to the cloned policy --base (default); demos: PPO's "
                             "actor pretrained on --demos demonstrations; scratch: PPO alone")
    parser.add_argument("--base", type=pathlib.Path, default=BASE,
                        help=f"the residual's base policy file (default {BASE}, bc.py's)")
    parser.add_argument("--residual-scale", type=float, default=0.1,
                        help="the residual's largest correction, in normalised action units (default 0.1)")
    parser.add_argument("--learning-rate", type=float,
                        help="PPO's Adam rate (default 3e-5 from a start, 3e-4 from scratch: a cloned policy's "
                             "success went from 85 %% to 0 %% within 30,000 steps at 1e-4)")
    parser.add_argument("--epochs", type=int, default=5, help="PPO's epochs over each rollout (default 5)")
    parser.add_argument("--demos", type=int, default=500,
                        help="with --start demos: scripted demonstrations, seeds 0 to N - 1 (default 500)")
    parser.add_argument("--data", type=pathlib.Path, default=pathlib.Path("data") / "demos",
                        help="where the demonstrations' datasets are, DATA/state/grasp_lift (written there when missing)")
    parser.add_argument("--pretrain-updates", type=int, default=20_000,
                        help="Adam steps training the actor on the demonstrations (default 20000)")
    parser.add_argument("--critic-warmup", type=int, default=10,
                        help="rollouts that train the critic alone before the actor moves (default 10)")
    parser.add_argument("--eval-every", type=int, default=100_000, help="environment steps between evaluations")
    parser.add_argument("--eval-seeds", type=common.seed_range, default=range(2000, 2020),
                        help="the learning curve's unseen seeds A:B (default 2000:2020)")
    parser.add_argument("--final-seeds", type=common.seed_range, default=range(2000, 2100),
                        help="the trained policy's unseen seeds A:B (default 2000:2100, bc.py's)")
    parser.add_argument("--policy-out", type=pathlib.Path, default=POLICY,
                        help=f"with --start residual: the trained policy's file (default {POLICY})")
    parser.add_argument("--out", type=pathlib.Path, default=OUT, help=f"the results JSON (default {OUT})")
    args = parser.parse_args(argv)

    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.callbacks import BaseCallback
    from stable_baselines3.common.vec_env import DummyVecEnv, VecMonitor, VecNormalize

    from viscera.scale.gym_env import TaskEnv

    first_unseen = min(min(args.eval_seeds), min(args.final_seeds))
    if args.start == "demos" and args.demos > first_unseen:
        parser.error(f"--demos {args.demos}: the demonstrations' seeds 0:{args.demos} reach the evaluation's")
    base_entry = None
    if args.start == "residual":
        from viscera import policy_file
        try:
            base = policy_file.load(args.base)
            base.check_task(TASK)
        except policy_file.PolicyFileError as error:
            parser.error(f"--base {error}")  # the error names the file
        architecture = base.meta["architecture"]
        if architecture.get("residual") is not None:
            parser.error(f"--base {args.base}: a residual policy already; give the policy it corrects")
        if not {"state", "clock"} <= set(architecture["inputs"]):
            parser.error(f"--base {args.base}: reads {architecture['inputs']}; a residual's base reads the state and "
                         "the clock, which its correction reads too")
        seeds = base.meta["training"].get("demonstration_seeds", [0, 0])
        if seeds[1] >= first_unseen:
            parser.error(f"--base {args.base}: its demonstrations' seeds {seeds} reach the evaluation's")
        record_path = pathlib.Path(bc.OUT)
        if record_path.exists():  # what the base cost: its training, from bc.py's record
            base_entry = json.loads(record_path.read_text())["results"].get(TASK, {}).get("state")
            if base_entry is not None and pathlib.Path(base_entry["policy_file"]).name != args.base.name:
                base_entry = None
    torch.set_num_threads(1)
    budget_s = args.budget_core_hours * 3600.0
    clock = common.Clock()  # this process's CPU and its finished children's (a collection's workers)
    spent = {"cpu_s": 0.0}

    def cpu_s() -> float:
        spent["cpu_s"] += clock.lap()["cpu_s"]
        return spent["cpu_s"]

    start = {"kind": args.start}
    if args.start == "demos":
        start["demonstrations"] = args.demos
        collected = bc.collect(args.data / "state", TASK, args.demos, pixels=False, workers=1)
        frames = bc.load_demonstrations(args.data / "state" / TASK, TASK, pixels=False, limit=args.demos)
        start.update(collected_here=collected, demonstrations_cloned=frames["episodes"],
                     demonstration_env_steps=frames["collected_steps"])
    elif args.start == "residual":
        start.update(base=str(args.base), base_sha256=base.sha256, residual_scale=args.residual_scale,
                     demonstration_env_steps=int(base.meta["training"].get("env_steps", 0)),
                     base_training_cpu_s=None if base_entry is None else
                     base_entry["train_cpu_s"] + base_entry["dagger_cpu_s"],
                     base_success_rate=None if base_entry is None else base_entry["success_rate"])
        spent["cpu_s"] += start["base_training_cpu_s"] or 0.0  # the base's training is in the budget

    def make_env(shaped: bool = True):
        """The learner's environment; unshaped, the task's own returns (the curve's)."""
        gamma = GAMMA if shaped else None
        if args.start == "residual":
            return with_memory(TaskEnv(TASK), args.base, args.residual_scale, gamma)
        return with_memory(TaskEnv(TASK), gamma=gamma)

    def unshaped():
        return make_env(shaped=False)

    # seeded at the first reset (from PPO's seed): environment i from task seed i
    # a residual's inputs are normalised already, as its policy file normalises them
    venv = VecNormalize(VecMonitor(DummyVecEnv([make_env] * args.envs)), norm_obs=args.start != "residual",
                        norm_reward=False, clip_obs=10.0)
    started = args.start != "scratch"
    rate = args.learning_rate if args.learning_rate is not None else 3e-5 if started else 3e-4
    hyper = dict(n_steps=1024, batch_size=256, n_epochs=args.epochs, learning_rate=rate,
                 gamma=GAMMA, gae_lambda=0.95, clip_range=0.2, ent_coef=0.0, target_kl=0.01 if started else None,
                 policy_kwargs=dict(net_arch=[256, 256], log_std_init=-1.5 if started else -0.5))
    policy_kwargs = dict(hyper["policy_kwargs"])
    if args.start == "residual":  # ReLU, which a policy file's dense layers have
        policy_kwargs["activation_fn"] = torch.nn.ReLU
        hyper["policy_kwargs"] = dict(hyper["policy_kwargs"], activation_fn="relu")
    model = PPO("MlpPolicy", venv, seed=0, verbose=0, device="cpu", **dict(hyper, policy_kwargs=policy_kwargs))
    if args.start == "demos":
        start.update(pretrain(model, venv, frames, args.pretrain_updates))
    if args.start == "residual":
        with torch.no_grad():  # no correction at the start: the base policy as it is
            model.policy.action_net.weight.zero_()
            model.policy.action_net.bias.zero_()
    if started:
        start["critic_warmup_rollouts"] = args.critic_warmup
    curve: list[dict] = []
    algorithm = {"residual": "PPO (stable-baselines3), residual on the cloned policy",
                 "demos": "PPO (stable-baselines3), actor pretrained on demonstrations", "scratch": "PPO (stable-baselines3)"}
    record = {"task": TASK, "algorithm": algorithm[args.start],
              "hyperparameters": hyper, "start": start,
              "reward": "the task's dense reward, made potential-based for gamma: + (gamma - 1) Phi(s') on every step "
                        "that does not end the episode",
              "envs": args.envs, "budget_core_hours": args.budget_core_hours,
              "train_seeds": f"environment i starts on task seed i (0 to {args.envs - 1}), then draws from its RandomState",
              "eval_seeds": [min(args.eval_seeds), max(args.eval_seeds)],
              "final_seeds": [min(args.final_seeds), max(args.final_seeds)], "curve": curve,
              "versions": common.versions("stable_baselines3", "torch")}

    record["attempts"] = earlier_attempts(args.out)
    references_clock = common.Clock()
    record["references_on_eval_seeds"] = references(list(args.eval_seeds))
    record["references_note"] = ("the scripted policy and uniform random actions on the curve's seeds, the same "
                                 "episode returns (their CPU time is not in the budget)")
    spent["cpu_s"] -= references_clock.lap()["cpu_s"]

    def write():
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(record, indent=1) + "\n")

    demo_steps = start.get("demonstration_env_steps", 0)

    def point(steps: int) -> None:
        """The curve's point at `steps` of PPO (plus the demonstrations' steps), its evaluation counted in the budget."""
        used = cpu_s()
        result = evaluate(model, venv, unshaped, list(args.eval_seeds))
        curve.append({"env_steps": int(steps) + demo_steps, "ppo_env_steps": int(steps), "core_hours": used / 3600.0,
                      "success_rate": result["success_rate"], "mean_return": result["mean_return"]})
        print(f"{steps:>9} steps  {used / 3600:.3f} core-h  success {result['success_rate']:.2f}"
              f"  return {result['mean_return']:.1f}", flush=True)
        write()

    actor = [p for name, p in model.policy.named_parameters()
             if name.startswith(("mlp_extractor.policy_net", "action_net", "log_std"))]

    class Curve(BaseCallback):
        """Evaluates on the unseen seeds every `eval_every` steps; holds the actor for the critic's
        warm-up rollouts; stops once the budget is spent."""

        def __init__(self):
            super().__init__()
            self.next_eval = args.eval_every
            self.rollouts = 0

        def _on_training_start(self) -> None:
            for parameter in actor:
                parameter.requires_grad_(not (started and args.critic_warmup))

        def _on_step(self) -> bool:
            return cpu_s() <= budget_s

        def _on_rollout_end(self) -> None:
            self.rollouts += 1
            if self.rollouts == args.critic_warmup + 1:
                for parameter in actor:
                    parameter.requires_grad_(True)
            steps = self.num_timesteps
            if steps >= self.next_eval:
                self.next_eval = steps + args.eval_every
                point(steps)

    point(0)  # the start: the pretrained actor (or PPO's initial one)

    wall_start = time.perf_counter()
    model.learn(total_timesteps=10 ** 9, callback=Curve())
    record["train_env_steps"] = int(model.num_timesteps)
    record["train_core_hours"] = cpu_s() / 3600.0
    record["train_wall_s"] = time.perf_counter() - wall_start
    model.save(args.out.with_suffix(".zip"))
    venv.save(str(args.out.with_suffix(".normalizer.pkl")))
    if args.start == "residual":  # the policy file, evaluated as `play --policy` runs it
        trained = export(model, args.base, args.residual_scale, args.policy_out, training={
            "by": "python/tools/learning/rl_grasp_lift.py", "algorithm": record["algorithm"], "base": str(args.base),
            "base_sha256": base.sha256, "residual_scale": args.residual_scale, "ppo_env_steps": int(model.num_timesteps),
            "core_hours": record["train_core_hours"], "train_seeds": record["train_seeds"],
            "versions": record["versions"]})
        check_export(trained, model, unshaped, args.residual_scale)
        record["policy_file"] = str(args.policy_out)
        record.update(policy_sha256=trained.sha256, policy_bytes=args.policy_out.stat().st_size,
                      base_demonstration_seeds=base.meta["training"].get("demonstration_seeds"))
        evaluation_clock = common.Clock()
        final = bc.evaluate(pathlib.Path(trained.path), args.final_seeds)
        final["eval_cpu_s"] = evaluation_clock.lap()["cpu_s"]
        if final["success_rate"] >= 0.1:
            noisy = bc.evaluate(pathlib.Path(trained.path), args.final_seeds, noise=bc.ACTION_NOISE)
            final["action_noise"] = {"share_of_range": bc.ACTION_NOISE, "success_rate": noisy["success_rate"],
                                     "success_interval_95": noisy["success_interval_95"]}
    else:
        final = evaluate(model, venv, unshaped, list(args.final_seeds))
    record["final"] = final
    write()
    common.curve_figure(record, args.out.with_suffix(".png"))
    print(f"final: success {final['success_rate']:.2f} on {len(args.final_seeds)} unseen seeds")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
