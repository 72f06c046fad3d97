"""Command line: ``python -m viscera run SCENE.xml --duration 5 [--png out.png]``."""

from __future__ import annotations

import argparse
import os
import sys
import time

import viscera  # first: it picks a headless GL backend before mujoco loads

import mujoco  # noqa: E402
import numpy as np  # noqa: E402
from tqdm import tqdm  # noqa: E402


def _render_png(model: mujoco.MjModel, data: mujoco.MjData, path: str, camera: str | None) -> None:
    import matplotlib.image
    width = min(800, int(model.vis.global_.offwidth))
    height = min(600, int(model.vis.global_.offheight))
    with mujoco.Renderer(model, height, width, max_geom=20000) as renderer:
        cam = camera if camera is not None else (0 if model.ncam > 0 else -1)
        renderer.update_scene(data, camera=cam)
        matplotlib.image.imsave(path, renderer.render())


def run(scene: str, duration: float, png: str | None, camera: str | None, quiet: bool) -> dict:
    """Simulate `scene` for `duration` s with a progress bar; return the summary figures."""
    model = mujoco.MjModel.from_xml_path(scene)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    steps = int(round(duration / model.opt.timestep))
    chunk = max(1, steps // 200)
    wall_start = time.perf_counter()
    with tqdm(total=steps, unit="step", disable=quiet, desc=os.path.basename(scene)) as bar:
        done = 0
        while done < steps:
            count = min(chunk, steps - done)
            for _ in range(count):
                mujoco.mj_step(model, data)
            done += count
            bar.update(count)
    wall = time.perf_counter() - wall_start
    summary = {"scene": scene, "simulated_s": data.time, "wall_s": wall,
               "real_time_factor": data.time / wall if wall > 0 else float("inf"), "intestines": []}
    for gut in viscera.intestines(model):
        axis = gut.axis_points(data, 4000)
        summary["intestines"].append({
            "name": gut.name, "rest_length_m": gut.rest_length, "final_length_m": gut.length(data),
            "lowest_point_m": float(axis[:, 2].min()), "max_speed_m_s": float(np.abs(gut.velocities(data)).max()),
            "divergences": gut.divergence_count(data)})
    if png:
        _render_png(model, data, png, camera)
        summary["png"] = png
    return summary


def _print_summary(s: dict) -> None:
    print(f"scene            {s['scene']}")
    print(f"simulated time   {s['simulated_s']:.3f} s")
    print(f"wall time        {s['wall_s']:.3f} s")
    print(f"real-time factor {s['real_time_factor']:.2f}x  ({s['wall_s'] / max(s['simulated_s'], 1e-12):.3f} wall s per simulated s)")
    for g in s["intestines"]:
        print(f"intestine '{g['name']}': length {g['final_length_m']:.4f} m (rest {g['rest_length_m']:.4f} m), "
              f"lowest axis point z = {g['lowest_point_m']:.4f} m, max speed {g['max_speed_m_s']:.3g} m/s, "
              f"divergences {g['divergences']}")
    if "png" in s:
        print(f"picture          {s['png']}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m viscera", description=__doc__)
    commands = parser.add_subparsers(dest="command", required=True)
    run_parser = commands.add_parser("run", help="simulate an MJCF scene and print a summary")
    run_parser.add_argument("scene", help="MJCF file, e.g. assets/scenes/fall_on_plane.xml")
    run_parser.add_argument("--duration", type=float, default=5.0, help="simulated seconds (default 5)")
    run_parser.add_argument("--png", help="render the final state to this PNG file")
    run_parser.add_argument("--camera", help="camera name for --png (default: the scene's first camera)")
    run_parser.add_argument("--quiet", action="store_true", help="no progress bar")
    args = parser.parse_args(argv)
    if args.duration <= 0:
        parser.error(f"--duration must be positive, got {args.duration}")
    _print_summary(run(args.scene, args.duration, args.png, args.camera, args.quiet))
    return 0


if __name__ == "__main__":
    sys.exit(main())
