"""Pixel observations' cost: env steps per second with pixels off and on, per frame size, where a
frame's time goes, and the peer: MuJoCo's own renderer at the scene's defaults, in this process.

    python python/tools/bench_pixels.py [--task clear_area] [--sizes 84 128 256] [--steps 100] [--runs 5]
        [--json docs/pixels/bench.json]

Per size, the variants alternate within each run (pixels off, then on), each `steps` control
steps of the task's scripted policy after a reset with the same seed; medians over `runs`.
A frame's parts are timed on the settled first state, 50 frames each, medians:
- scene update: mjv_updateScene (the plugin's capsules included) and the light selection;
- render: the two draws (RGB with depth, then segmentation) on the camera's GL thread;
- read-back: mjr_readPixels of both;
- labels and arrays: segment ids to labels, the depth buffer to metres, the arrays flipped;
- the whole frame, as an observation costs (the parts and the hops to the GL thread).
The peer renders the same state through mujoco.Renderer (RGB only) at the model's defaults
(28 x 16 capsule tessellation, 4x multisampling, shadows, reflections, the scene's 500-odd
capsules), from the laparoscope and from the `top` camera.
"""

from __future__ import annotations

import argparse
import json
import pathlib
import statistics
import time

import viscera.tasks  # first: it picks a headless GL backend before MuJoCo loads

import mujoco  # noqa: E402
from tqdm import tqdm  # noqa: E402

from viscera import cli  # noqa: E402

OUT = pathlib.Path("docs") / "pixels" / "bench.json"


def steps_per_second(task: str, pixels: bool, size: int, steps: int, seed: int = 0) -> float:
    env = viscera.tasks.load(task, seed=seed, pixels=pixels, width=size, height=size)
    policy = viscera.tasks.scripted_policy(env)
    step = env.reset()
    start = time.perf_counter()
    done = 0
    for done in range(1, steps + 1):
        step = env.step(policy(step))
        if step.last():  # the next step would time an automatic reset
            break
    rate = done / (time.perf_counter() - start)
    viscera.tasks.close(env)
    return rate


def _median_ms(function, count: int = 50) -> float:
    function()
    times = []
    for _ in range(count):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return 1e3 * statistics.median(times)


def frame_parts(task: str, size: int) -> dict:
    """Milliseconds per part of one frame (module doc), on the first state of seed 0."""
    env = viscera.tasks.load(task, seed=0, pixels=True, width=size, height=size)
    env.reset()
    camera, physics = env.task.camera, env.physics
    model, data = physics.model.ptr, physics.data.ptr
    scene, gl = camera._scene, camera._gl  # the camera's own parts, timed one by one

    def update():
        camera._update(model, data)

    def draws():
        mujoco.mjr_render(camera._viewport, scene, gl.context)
        scene.flags[mujoco.mjtRndFlag.mjRND_SEGMENT] = scene.flags[mujoco.mjtRndFlag.mjRND_IDCOLOR] = 1
        mujoco.mjr_render(camera._viewport, scene, gl.context)
        scene.flags[mujoco.mjtRndFlag.mjRND_SEGMENT] = scene.flags[mujoco.mjtRndFlag.mjRND_IDCOLOR] = 0
        mujoco.mjr_finish()  # the draws done, not only queued

    def read_back():
        mujoco.mjr_readPixels(camera._rgb, camera._depth, camera._viewport, gl.context)
        mujoco.mjr_readPixels(camera._ids, None, camera._viewport, gl.context)

    update()
    parts = {"scene update": _median_ms(update),
             "render": gl.call(_median_ms, draws),
             "read-back": gl.call(_median_ms, read_back),
             "labels and arrays": _median_ms(lambda: camera._arrays(model, scene)),
             "whole frame": _median_ms(lambda: camera.render(physics))}
    viscera.tasks.close(env)
    return parts


def peer_ms(task: str, size: int) -> dict:
    """MuJoCo's renderer at the model's own settings, RGB only, same state as frame_parts."""
    env = viscera.tasks.load(task, seed=0)
    env.reset()
    physics = env.physics
    out = {}
    with mujoco.Renderer(physics.model.ptr, size, size) as renderer:
        for camera in ("laparoscope", "top"):
            def frame():
                renderer.update_scene(physics.data.ptr, camera)
                renderer.render()
            out[camera] = _median_ms(frame, count=10)
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python python/tools/bench_pixels.py", description=__doc__.split("\n")[0])
    parser.add_argument("--task", choices=viscera.tasks.ALL, default="clear_area", help="task (default clear_area)")
    parser.add_argument("--sizes", type=cli.positive_int, nargs="+", default=[84, 128, 256],
                        help="square frame sizes in pixels (default 84 128 256)")
    parser.add_argument("--steps", type=cli.positive_int, default=100, help="control steps per run (default 100)")
    parser.add_argument("--runs", type=cli.positive_int, default=5, help="runs per variant, medians (default 5)")
    parser.add_argument("--json", type=cli.output_file(".json"), help=f"write the figures here (e.g. {OUT})")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    args = parser.parse_args(argv)
    rows = []
    with tqdm(total=len(args.sizes) * (2 * args.runs + 2), desc="pixel benchmark", disable=args.quiet) as bar:
        for size in args.sizes:
            rates = {"off": [], "on": []}
            for _ in range(args.runs):  # alternated: the machine's drift hits both alike
                for variant in ("off", "on"):
                    rates[variant].append(steps_per_second(args.task, variant == "on", size, args.steps))
                    bar.update()
            parts = frame_parts(args.task, size)
            bar.update()
            peer = peer_ms(args.task, size)
            bar.update()
            rows.append({"size": size, "steps_per_s_off": statistics.median(rates["off"]),
                         "steps_per_s_on": statistics.median(rates["on"]), "frame_ms": parts,
                         "peer_ms": peer, "speedup_over_peer": peer["laparoscope"] / parts["whole frame"]})
    print(f"{args.task}, scripted policy, {args.steps} control steps after a reset, medians of {args.runs}; "
          "a frame is RGB + depth + segmentation")
    for r in rows:
        f = r["frame_ms"]
        print(f"{r['size']:4d} x {r['size']:<4d} env steps/s: pixels off {r['steps_per_s_off']:6.1f}, on "
              f"{r['steps_per_s_on']:6.1f} | frame {f['whole frame']:5.2f} ms (update {f['scene update']:.2f}, "
              f"render {f['render']:.2f}, read-back {f['read-back']:.2f}, labels {f['labels and arrays']:.2f}) | "
              f"MuJoCo's renderer at the defaults, RGB only: laparoscope {r['peer_ms']['laparoscope']:.0f} ms, "
              f"top {r['peer_ms']['top']:.0f} ms ({r['speedup_over_peer']:.0f}x)")
    if args.json:
        pathlib.Path(args.json).write_text(json.dumps({"task": args.task, "steps": args.steps, "runs": args.runs,
                                                       "rows": rows}, indent=1) + "\n")
        print(f"wrote {args.json}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
