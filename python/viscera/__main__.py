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


def run(scene: str, duration: float, png: str | None, camera: str | None, quiet: bool, viewer: str | None = None,
        record: str | None = None, record_fps: float = 10.0, host: str = "127.0.0.1") -> dict:
    """Simulate `scene` for `duration` s with a progress bar; return the summary figures.

    With `viewer="meshcat"` the run is shown live (paced to real time, 30 frames per
    simulated second) at a loopback URL; `record` writes a self-contained HTML
    recording at `record_fps`.
    """
    model = mujoco.MjModel.from_xml_path(scene)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    steps = int(round(duration / model.opt.timestep))
    view = None
    if viewer == "meshcat" or record:
        from viscera.viewer import MeshcatViewer
        view = MeshcatViewer(model, host=host)
        print(f"meshcat viewer: {view.url}", flush=True)
    live = viewer == "meshcat"
    display_every = max(1, int(round(1.0 / (30.0 * model.opt.timestep))))
    record_every = max(1, int(round(1.0 / (record_fps * model.opt.timestep))))
    chunk = max(1, steps // 200) if not live else display_every
    wall_start = time.perf_counter()
    stepping = 0.0
    try:
        if view is not None:
            view.update(data)
        with tqdm(total=steps, unit="step", disable=quiet, desc=os.path.basename(scene)) as bar:
            done = 0
            while done < steps:
                count = min(chunk, steps - done)
                tick = time.perf_counter()
                for _ in range(count):
                    mujoco.mj_step(model, data)
                    done += 1
                    if record and done % record_every == 0:
                        view.record(data)
                stepping += time.perf_counter() - tick
                bar.update(count)
                if live:
                    view.update(data)
                    ahead = data.time - (time.perf_counter() - wall_start)
                    if ahead > 0:
                        time.sleep(ahead)  # pace the live view to real time
        summary_extra = {}
        if record:
            size = view.save(record, fps=record_fps)
            summary_extra["recording"] = record
            summary_extra["recording_bytes"] = size
            summary_extra["recording_frames"] = len(view.frames)
    finally:
        if view is not None:
            view.close()
    wall = stepping
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
    summary.update(summary_extra)
    return summary


def _print_summary(s: dict) -> None:
    print(f"scene            {s['scene']}")
    print(f"simulated time   {s['simulated_s']:.3f} s")
    print(f"wall time        {s['wall_s']:.3f} s (stepping only)")
    print(f"real-time factor {s['real_time_factor']:.2f}x  ({s['wall_s'] / max(s['simulated_s'], 1e-12):.3f} wall s per simulated s)")
    for g in s["intestines"]:
        print(f"intestine '{g['name']}': length {g['final_length_m']:.4f} m (rest {g['rest_length_m']:.4f} m), "
              f"lowest axis point z = {g['lowest_point_m']:.4f} m, max speed {g['max_speed_m_s']:.3g} m/s, "
              f"divergences {g['divergences']}")
    if "png" in s:
        print(f"picture          {s['png']}")
    if "recording" in s:
        print(f"recording        {s['recording']} ({s['recording_frames']} frames, {s['recording_bytes'] / 1e6:.1f} MB)")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m viscera", description=__doc__)
    commands = parser.add_subparsers(dest="command", required=True)
    run_parser = commands.add_parser("run", help="simulate an MJCF scene and print a summary")
    run_parser.add_argument("scene", help="MJCF file, e.g. assets/scenes/fall_on_plane.xml")
    run_parser.add_argument("--duration", type=float, default=5.0, help="simulated seconds (default 5)")
    run_parser.add_argument("--png", help="render the final state to this PNG file")
    run_parser.add_argument("--camera", help="camera name for --png (default: the scene's first camera)")
    run_parser.add_argument("--quiet", action="store_true", help="no progress bar")
    run_parser.add_argument("--viewer", choices=["meshcat"], help="show the run live in a browser (meshcat)")
    run_parser.add_argument("--record", help="write a self-contained HTML recording of the run to this file")
    run_parser.add_argument("--record-fps", type=float, default=10.0, help="recorded frames per simulated second")
    run_parser.add_argument("--host", default="127.0.0.1", help="address the viewer serves on (default: loopback only)")
    args = parser.parse_args(argv)
    if args.duration <= 0:
        parser.error(f"--duration must be positive, got {args.duration}")
    if args.record_fps <= 0:
        parser.error(f"--record-fps must be positive, got {args.record_fps}")
    _print_summary(run(args.scene, args.duration, args.png, args.camera, args.quiet, args.viewer, args.record,
                       args.record_fps, args.host))
    return 0


if __name__ == "__main__":
    sys.exit(main())
