"""Pictures of the pixel observations for docs/pixels.md: the laparoscope's view of clear_area
before and after the clearing gesture, each as RGB | depth | segmentation side by side.

    python python/tools/pixel_pictures.py [--seed 0] [--size 256] [--out docs/pixels]

The picture after is the episode's last frame: a lasting success ends it (or the time limit);
the episode's outcome goes to episode.json beside the pictures (the page quotes it).
Depth is drawn grey, near bright, from the frame's nearest to its farthest point; segmentation
in the labels' colours: nothing black, intestine pink, tools grey, target green.
"""

from __future__ import annotations

import argparse
import json
import pathlib

import viscera.tasks  # first: it picks a headless GL backend

import numpy as np  # noqa: E402

from viscera import cli, pixels  # noqa: E402

PALETTE = np.zeros((256, 3), np.uint8)
PALETTE[pixels.LABELS["intestine"]] = (230, 120, 120)
PALETTE[pixels.LABELS["tool"]] = (160, 160, 170)
PALETTE[pixels.LABELS["target"]] = (50, 200, 80)


def strip(observation: dict) -> np.ndarray:
    """RGB, depth (grey, near bright) and segmentation (PALETTE) side by side, 4 pixels apart."""
    depth = observation["depth"].astype(float)
    grey = (255 * (depth.max() - depth) / max(depth.max() - depth.min(), 1e-9)).astype(np.uint8)
    height = depth.shape[0]
    gap = np.full((height, 4, 3), 255, np.uint8)
    return np.concatenate([observation["pixels"], gap, np.repeat(grey[..., None], 3, axis=-1), gap,
                           PALETTE[observation["segmentation"]]], axis=1)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python python/tools/pixel_pictures.py", description=__doc__.split("\n")[0])
    parser.add_argument("--seed", type=cli.natural_int, default=0, help="clear_area's seed (default 0)")
    parser.add_argument("--size", type=cli.positive_int, default=256, help="frame size in pixels (default 256)")
    parser.add_argument("--out", type=pathlib.Path, default=pathlib.Path("docs") / "pixels",
                        help="folder (default docs/pixels)")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    env = viscera.tasks.load("clear_area", seed=args.seed, pixels=True, width=args.size, height=args.size)
    policy = viscera.tasks.scripted_policy(env)
    step = env.reset()
    cli.save_png(str(args.out / "laparoscope_before.png"), strip(step.observation))
    while not step.last():
        step = env.step(policy(step))
    cli.save_png(str(args.out / "laparoscope_after.png"), strip(step.observation))
    episode = {"task": "clear_area", "seed": args.seed, "success": bool(env.task.success(env.physics)),
               "simulated_s": round(float(env.physics.data.time), 2)}
    (args.out / "episode.json").write_text(json.dumps(episode, indent=2) + "\n")
    print(f"clear_area seed {args.seed}: success {episode['success']} at {episode['simulated_s']:.2f} s; wrote "
          f"{args.out}/laparoscope_before.png, laparoscope_after.png, episode.json")
    viscera.tasks.close(env)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
