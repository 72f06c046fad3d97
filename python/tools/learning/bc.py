"""Behaviour cloning from the scripted demonstrations, on every task, from the state observations
and, apart, from the laparoscope's pixels; evaluated on 50 seeds no demonstration used, with
the assessment's scores; written to docs/learning/bc.json.

    pip install ".[learning]"
    python python/tools/learning/bc.py [--tasks clear_area grasp_lift ...] [--observations state pixels]
        [--demos-state 200] [--demos-pixels 50] [--data data/demos] [--eval-seeds 2000:2050] [--workers 2]
        [--out docs/learning/bc.json]

- The demonstrations: `python -m viscera dataset TASK --policy scripted --seeds 0:N --format minari
  [--pixels] --out DATA/KIND/TASK` (this script writes them when missing), read back with
  Minari's loader: 200 episodes for the state policies, 50 with pixels for the pixel policies
  (a frame with pixels costs 6 ms to collect). Only the demonstrations that succeeded are cloned.
- What a policy sees, never the privileged state:
  - `state`: gymnasium's flat state observation (the task's own entries: tool joints and forces,
    the grasp, the intestine's axis points, gravity, the task's target);
  - `pixels`: the laparoscope's 84 x 84 RGB and the tools' joints (what a robot knows of itself);
  - both also get the policy's own memory: its clock (the control steps it has taken, as a
    fraction of the time limit) and its previous command. The demonstrator's phases are timed and
    its commands are velocity-limited ramps, which the tools' measured joints lag behind: without
    them a cloned policy cannot tell where along a ramp it is.
- The model: an MLP (state) or a small convolutional network (pixels) regressing the change of the
  normalised command from the previous one (scaled by its spread), mean squared error, Adam, on
  one CPU thread.
"""

from __future__ import annotations

import argparse
import concurrent.futures
import json
import multiprocessing
import pathlib
import sys
import time

import numpy as np
import torch
from torch import nn

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import common  # noqa: E402

OUT = pathlib.Path("docs") / "learning" / "bc.json"
TASKS = ("clear_area", "grasp_lift", "retract_reach", "run_the_bowel")
PROPRIOCEPTION = ("tool_joints",)  # the state entries a pixel policy also gets


def proprioception_slices(names: list[str]) -> np.ndarray:
    """Indices of the state vector's PROPRIOCEPTION entries (names "key[i]")."""
    return np.array([i for i, name in enumerate(names) if name.split("[")[0] in PROPRIOCEPTION])


def load_demonstrations(root: pathlib.Path, task: str, pixels: bool, limit: int | None = None) -> dict:
    """The successful demonstrations' (input, action) pairs, read with Minari's loader."""
    from viscera import datasets

    dataset = datasets.load(root, "minari", task, "scripted")
    spec_kwargs = dataset.env_spec.kwargs
    from viscera.scale.gym_env import TaskEnv
    env = TaskEnv(**spec_kwargs)
    names = common.state_names(env)
    action_names = list(env.dm_env.physics.named.data.ctrl.axes.row.names)
    time_limit_steps = int(round(env.dm_env.time_limit_s / env.dm_env.control_timestep()))
    env.close()
    states, images, clocks, actions, previous = [], [], [], [], []
    used, seeds = 0, []
    metadata = list(dataset.storage.get_episode_metadata(dataset.episode_indices))
    for episode, meta in zip(dataset.iterate_episodes(), metadata):
        if not episode.infos["is_success"][-1]:
            continue
        if limit is not None and used >= limit:
            break
        used += 1
        seeds.append(int(meta["seed"]))
        steps = len(episode.actions)
        observation = episode.observations
        state = observation["state"][:steps] if isinstance(observation, dict) else observation[:steps]
        states.append(state)
        if pixels:
            images.append(observation["pixels"][:steps])
        clocks.append(np.arange(steps) / time_limit_steps)
        labels = episode.infos["demonstrator_action"][1:] if "demonstrator_action" in episode.infos else episode.actions
        actions.append(labels)  # what the script commanded
        # the policy's own previous command (the action taken, noise and all): zeros before the first
        previous.append(np.concatenate([np.zeros_like(episode.actions[:1]), episode.actions[:-1]]))
    if not used:
        raise SystemExit(f"{root}: no successful demonstration to clone")
    return {"seeds": seeds, "action_names": action_names, "state": np.concatenate(states), "pixels": np.concatenate(images) if pixels else None,
            "clock": np.concatenate(clocks), "action": np.concatenate(actions),
            "previous_action": np.concatenate(previous), "episodes": used,
            "total_episodes": dataset.total_episodes, "names": names, "time_limit_steps": time_limit_steps}


class StatePolicy(nn.Module):
    """An MLP from the state and the policy's memory."""

    def __init__(self, state_size: int, memory_size: int, action_size: int):
        super().__init__()
        self.net = nn.Sequential(nn.Linear(state_size + memory_size, 512), nn.ReLU(), nn.Linear(512, 512), nn.ReLU(),
                                 nn.Linear(512, action_size))

    def forward(self, state, memory, image=None):
        return self.net(torch.cat([state, memory], dim=1))


class PixelPolicy(nn.Module):
    """A small convolutional network (DQN's) on the RGB, then an MLP with the proprioception and memory."""

    def __init__(self, state_size: int, memory_size: int, action_size: int):
        super().__init__()
        self.conv = nn.Sequential(nn.Conv2d(3, 32, 8, stride=4), nn.ReLU(), nn.Conv2d(32, 64, 4, stride=2), nn.ReLU(),
                                  nn.Conv2d(64, 64, 3, stride=1), nn.ReLU(), nn.Flatten())
        with torch.no_grad():
            features = self.conv(torch.zeros(1, 3, *IMAGE_SIZE)).shape[1]
        self.head = nn.Sequential(nn.Linear(features + state_size + memory_size, 512), nn.ReLU(),
                                  nn.Linear(512, action_size))

    def forward(self, state, memory, image):
        return self.head(torch.cat([self.conv(image), state, memory], dim=1))


def build_model(kind: str, state_size: int, action_size: int):
    """The policy's network, from the inputs and its memory (its clock and its previous command) to
    the change of command, in units of its spread over the demonstrations."""
    return (StatePolicy if kind == "state" else PixelPolicy)(state_size, 1 + action_size, action_size)


class Cloned:
    """A trained policy as `act(observation)` for common.episode; remembers its own steps (the
    clock) and its previous command."""

    def __init__(self, model, kind, mean, std, inputs, time_limit_steps, action_size, change_scale, jaws):
        self.model, self.kind, self.mean, self.std, self.change_scale = model, kind, mean, std, change_scale
        self.jaws = jaws
        self.inputs, self.time_limit_steps, self.model_action_size = inputs, time_limit_steps, action_size
        self.reset()

    def reset(self):
        self.step = 0
        self.previous = None

    def __call__(self, observation):
        import torch

        state = observation["state"] if isinstance(observation, dict) else observation
        state = (state[self.inputs] - self.mean) / self.std
        if self.previous is None:
            self.previous = np.zeros(self.model_action_size)
        memory = np.concatenate([[self.step / self.time_limit_steps], self.previous])
        self.step += 1
        with torch.no_grad():
            image = None
            if self.kind == "pixels":
                image = torch.as_tensor(observation["pixels"], dtype=torch.float32).permute(2, 0, 1)[None] / 255.0
            action = self.model(torch.as_tensor(state, dtype=torch.float32)[None],
                                torch.as_tensor(memory, dtype=torch.float32)[None], image)
        output = action[0].numpy().astype(np.float64) * self.change_scale
        self.previous = np.clip(np.where(self.jaws, output, self.previous + output), -1.0, 1.0)
        return self.previous


def train(data: dict, kind: str, updates: int, seed: int = 0, batch: int | None = None,
          learning_rate: float = 1e-3) -> tuple:
    """The trained policy (Cloned), the training's wall and CPU seconds and its last loss."""
    import torch

    batch = batch or BATCH[kind]
    torch.manual_seed(seed)
    torch.set_num_threads(1)
    inputs = np.arange(data["state"].shape[1]) if kind == "state" else proprioception_slices(data["names"])
    state = data["state"][:, inputs]
    mean, std = state.mean(axis=0), state.std(axis=0) + 1e-6
    x = torch.as_tensor((state - mean) / std, dtype=torch.float32)
    memory = torch.as_tensor(np.concatenate([data["clock"][:, None], data["previous_action"]], axis=1),
                             dtype=torch.float32)
    # the target: the command's change from the previous one, scaled per actuator (a ramp's steps are
    # small next to the command itself: regressed directly, they drown in its error); a jaw's
    # command jumps (open, then shut at once): its target is the command itself
    jaws = np.array([name.endswith("_jaw") for name in data["action_names"]])
    change = np.where(jaws, data["action"], data["action"] - data["previous_action"])
    change_scale = change.std(axis=0) + 1e-6
    y = torch.as_tensor(change / change_scale, dtype=torch.float32)
    images = torch.as_tensor(data["pixels"]) if kind == "pixels" else None  # uint8, scaled per batch
    model = build_model(kind, len(inputs), y.shape[1])
    optimiser = torch.optim.Adam(model.parameters(), lr=learning_rate)
    generator = torch.Generator().manual_seed(seed)
    wall, cpu = time.perf_counter(), time.process_time()
    for _ in range(updates):
        index = torch.randint(len(y), (batch,), generator=generator)
        image = images[index].permute(0, 3, 1, 2).float() / 255.0 if images is not None else None
        loss = torch.mean((model(x[index], memory[index], image) - y[index]) ** 2)
        optimiser.zero_grad()
        loss.backward()
        optimiser.step()
    model.eval()
    policy = Cloned(model, kind, mean, std, inputs, data["time_limit_steps"], y.shape[1], change_scale, jaws)
    return policy, time.perf_counter() - wall, time.process_time() - cpu, float(loss.detach())


def collect(root: pathlib.Path, task: str, demos: int, pixels: bool, workers: int) -> None:
    """The task's scripted demonstrations as a Minari dataset at root/task, unless there already."""
    from viscera import datasets

    if (root / task).exists():
        return
    root.mkdir(parents=True, exist_ok=True)
    summary = datasets.write(task, root / task, "minari", demonstrator="scripted", seeds=range(demos), pixels=pixels,
                             workers=workers, progress=True)
    print(f"{task}: {summary['episodes']} demonstrations, {summary['successes']} successful, "
          f"{summary['wall_s']:.0f} s", flush=True)


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


def _evaluate(policy: Cloned, task: str, kind: str, seeds) -> list[dict]:
    from viscera.datasets import episodes

    torch.set_num_threads(1)  # one core per evaluating process
    from viscera.scale.gym_env import TaskEnv

    env = TaskEnv(**episodes.env_kwargs(task, "abdomen", kind == "pixels", IMAGE_SIZE))
    if kind == "pixels":
        env.dm_env.task.camera = RGBOnly(env.dm_env.task.camera)
    try:
        return [common.episode(env, policy, int(seed)) for seed in seeds]
    finally:
        env.close()


def evaluate(policy: Cloned, task: str, kind: str, seeds, workers: int = 1) -> dict:
    """common.summarise of the policy's episodes on `seeds`, in `workers` processes."""
    import torch

    torch.set_num_threads(1)
    if workers == 1:
        return common.summarise(_evaluate(policy, task, kind, seeds))
    parts = [list(part) for part in np.array_split(np.asarray(list(seeds)), workers) if len(part)]
    context = multiprocessing.get_context("spawn")
    with concurrent.futures.ProcessPoolExecutor(len(parts), mp_context=context) as pool:
        results = list(pool.map(_evaluate, [policy] * len(parts), [task] * len(parts), [kind] * len(parts), parts))
    return common.summarise([episode for part in results for episode in part])


IMAGE_SIZE = (84, 84)
UPDATES = {"state": 10_000, "pixels": 3_000}   # Adam steps
BATCH = {"state": 256, "pixels": 128}
DEMOS = {"state": 200, "pixels": 50}            # pixels cost 6 ms a frame to collect and 2 to evaluate


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python python/tools/learning/bc.py", description=__doc__.split("\n\n")[0])
    parser.add_argument("--tasks", nargs="+", choices=TASKS, default=list(TASKS), help="default: all four")
    parser.add_argument("--observations", nargs="+", choices=("state", "pixels"), default=["state", "pixels"],
                        help="what the policies see (default: both, each its own policy)")
    parser.add_argument("--demos-state", type=int, default=DEMOS["state"],
                        help="scripted episodes for the state policies (seeds 0 to N - 1)")
    parser.add_argument("--demos-pixels", type=int, default=DEMOS["pixels"],
                        help="scripted episodes with pixels for the pixel policies (seeds 0 to N - 1)")
    parser.add_argument("--data", type=pathlib.Path, default=pathlib.Path("data") / "demos",
                        help="where the demonstrations' datasets are (written there when missing)")
    parser.add_argument("--eval-seeds", type=common.seed_range, default=range(2000, 2050),
                        help="the unseen seeds A:B the policies are evaluated on (default 2000:2050)")
    parser.add_argument("--workers", type=int, default=2, help="processes collecting and evaluating")
    parser.add_argument("--out", type=pathlib.Path, default=OUT, help=f"the results JSON (default {OUT})")
    args = parser.parse_args(argv)
    demos = {"state": args.demos_state, "pixels": args.demos_pixels}
    if min(args.eval_seeds) < max(demos.values()):
        parser.error(f"--eval-seeds {min(args.eval_seeds)}:{max(args.eval_seeds) + 1} overlaps the demonstrations' "
                     f"seeds 0:{max(demos.values())}")

    record = json.loads(args.out.read_text()) if args.out.exists() else {"results": {}}
    record.update(eval_seeds=[min(args.eval_seeds), max(args.eval_seeds)], updates=UPDATES, batch=BATCH,
                  image_size=list(IMAGE_SIZE), versions=common.versions("torch", "minari"))
    for task in args.tasks:
        for kind in args.observations:
            root = args.data / kind
            collect(root, task, demos[kind], kind == "pixels", args.workers)
            data = load_demonstrations(root / task, task, pixels=kind == "pixels")
            overlap = sorted(set(data["seeds"]) & set(args.eval_seeds))
            if overlap:  # a dataset left from another run can hold any seeds: read, not assumed
                raise SystemExit(f"{root / task}: demonstrations on the evaluation's seeds {overlap[:5]}...")
            policy, wall_s, cpu_s, loss = train(data, kind, UPDATES[kind])
            print(f"{task} {kind}: trained on {data['episodes']} demonstrations ({len(data['action'])} frames) "
                  f"in {wall_s:.0f} s, loss {loss:.4f}; evaluating on {len(args.eval_seeds)} seeds", flush=True)
            result = evaluate(policy, task, kind, list(args.eval_seeds), args.workers)
            result.update(demonstrations=data["episodes"], demonstrations_collected=data["total_episodes"],
                          demonstration_seeds=[min(data["seeds"]), max(data["seeds"])], frames=len(data["action"]),
                          train_wall_s=wall_s, train_cpu_s=cpu_s, final_loss=loss, updates=UPDATES[kind],
                          batch=BATCH[kind], eval_seeds=[min(args.eval_seeds), max(args.eval_seeds)])
            record["results"].setdefault(task, {})[kind] = result
            print(f"{task} {kind}: success {result['success_rate']:.2f}", flush=True)
            args.out.parent.mkdir(parents=True, exist_ok=True)
            args.out.write_text(json.dumps(record, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
