"""Pictures of the anatomical abdomen for docs/cavity.md: the shipped scene from its top and
oblique cameras (MuJoCo's renderer), the laparoscope's view of a clear_area episode on it before
and after the clearing gesture (viscera's pixel camera: RGB | depth | segmentation), and the
meshcat viewer's page in headless Chromium.

    python python/tools/anatomical_pictures.py [--seed 1001] [--out docs/anatomical]

The episode's outcome goes to episode.json beside the pictures (the page quotes it). The meshcat
picture needs Debian's chromium (skipped, and said so, without it).
"""

from __future__ import annotations

import argparse
import json
import pathlib
import shutil
import subprocess
import tempfile

import viscera.tasks  # first: it picks a headless GL backend

import mujoco  # noqa: E402

from viscera import cli  # noqa: E402
from viscera.tasks import scene  # noqa: E402

import pixel_pictures  # noqa: E402


def scene_views(out: pathlib.Path) -> None:
    """top.png and oblique.png: the shipped scene at rest, MuJoCo's renderer."""
    model = mujoco.MjModel.from_xml_path(str(scene.scene_file(scene.SCENES["anatomical"].file)))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    with mujoco.Renderer(model, 600, 800) as renderer:
        for camera in ("top", "oblique"):
            renderer.update_scene(data, camera)
            cli.save_png(str(out / f"{camera}.png"), renderer.render())


def meshcat_view(out: pathlib.Path) -> bool:
    """meshcat.png: the viewer's live page on the shipped scene, from its top camera, screenshot
    by headless Chromium; False without chromium."""
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if chromium is None:
        return False
    from viscera.viewer import MeshcatViewer
    model = mujoco.MjModel.from_xml_path(str(scene.scene_file(scene.SCENES["anatomical"].file)))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    with MeshcatViewer(model, camera="top") as viewer:
        viewer.update(data)
        if viewer.flush() is None:
            raise RuntimeError("the meshcat server did not take the scene")
        subprocess.run([chromium, "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                        "--disable-component-update", "--disable-sync", "--no-first-run",
                        f"--user-data-dir={tempfile.mkdtemp()}", f"--screenshot={out / 'meshcat.png'}",
                        "--window-size=800,600", "--virtual-time-budget=6000", viewer.url],
                       capture_output=True, timeout=180, check=True)
    return True


def laparoscope(out: pathlib.Path, seed: int, size: int) -> dict:
    """laparoscope_before.png and laparoscope_after.png: clear_area on the anatomical abdomen."""
    env = viscera.tasks.load("clear_area", seed=seed, scene="anatomical", pixels=True, width=size, height=size)
    policy = viscera.tasks.scripted_policy(env)
    step = env.reset()
    cli.save_png(str(out / "laparoscope_before.png"), pixel_pictures.strip(step.observation))
    while not step.last():
        step = env.step(policy(step))
    cli.save_png(str(out / "laparoscope_after.png"), pixel_pictures.strip(step.observation))
    episode = {"task": "clear_area", "scene": "anatomical", "seed": seed,
               "success": bool(env.task.success(env.physics)), "simulated_s": round(float(env.physics.data.time), 2),
               "uncovered": round(env.task.measurements(env.physics).uncovered_fraction, 3)}
    viscera.tasks.close(env)
    return episode


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python python/tools/anatomical_pictures.py",
                                     description=__doc__.split("\n")[0])
    parser.add_argument("--seed", type=cli.natural_int, default=1001, help="clear_area's seed (default 1001)")
    parser.add_argument("--size", type=cli.positive_int, default=256, help="laparoscope frame size (default 256)")
    parser.add_argument("--out", type=pathlib.Path, default=pathlib.Path("docs") / "anatomical",
                        help="folder (default docs/anatomical)")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    scene_views(args.out)
    episode = laparoscope(args.out, args.seed, args.size)
    (args.out / "episode.json").write_text(json.dumps(episode, indent=2) + "\n")
    shown = meshcat_view(args.out)
    print(f"clear_area on the anatomical abdomen, seed {args.seed}: success {episode['success']} at "
          f"{episode['simulated_s']:.2f} s; wrote {args.out}/top.png, oblique.png, laparoscope_before.png, "
          f"laparoscope_after.png, episode.json" + (", meshcat.png" if shown else " (no chromium: no meshcat.png)"))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
