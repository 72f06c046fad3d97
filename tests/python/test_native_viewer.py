"""MuJoCo's own interactive viewer with the plugin: `python -m viscera view SCENE` and, from
Python, mujoco.viewer.launch_passive after `import viscera`, on a virtual X display (Xvfb), with
screenshots of the screen that must show the intestine's colour."""

from __future__ import annotations

import os
import pathlib
import shutil
import subprocess
import sys
import time

import numpy as np
import pytest
from PIL import ImageGrab

ROOT = pathlib.Path(__file__).resolve().parents[2]
ABDOMEN = ROOT / "assets" / "scenes" / "abdomen.xml"
NO_INTESTINE = """<mujoco><worldbody><light pos="0 0 1"/>
  <geom type="box" size="0.15 0.15 0.01" rgba="0.85 0.75 0.7 1"/></worldbody></mujoco>"""

pytestmark = pytest.mark.skipif(shutil.which("Xvfb") is None, reason="needs Xvfb (.ci/run installs it)")


def pink(display: str) -> tuple[int, np.ndarray]:
    """The screen, and its count of pixels of the intestine's colour (0.85, 0.45, 0.45) as lit:
    red well above green, green equal to blue."""
    screen = np.asarray(ImageGrab.grab(xdisplay=display)).astype(int)
    r, g, b = screen[..., 0], screen[..., 1], screen[..., 2]
    return int(np.count_nonzero((r > 120) & (g > 60) & (r > 1.4 * g) & (np.abs(g - b) < 25))), screen


def watch(display: str, process: subprocess.Popen, enough, seconds: float = 120.0) -> tuple[int, np.ndarray]:
    """Screenshots until `enough(count)` holds, the process ends or `seconds` pass; the last one."""
    deadline = time.monotonic() + seconds
    while True:
        count, screen = pink(display)
        if enough(count) or time.monotonic() > deadline:
            return count, screen
        try:
            process.wait(timeout=0.25)  # the process's end is the other thing worth waking for
            return pink(display)
        except subprocess.TimeoutExpired:
            pass


def environment(display: str) -> dict:
    env = dict(os.environ, DISPLAY=display)
    env.pop("MUJOCO_GL", None)  # the viewer is GLFW on the display
    return env


def stop(process: subprocess.Popen) -> str:
    process.terminate()
    _, err = process.communicate(timeout=60)
    return err


def test_view_command_shows_the_intestine_in_mujocos_viewer(display, tmp_path):
    """The viewer's panels have pink outlines of their own: the abdomen's screen must hold more
    of the intestine's colour than a scene without an intestine, by the bowel's pixels."""
    empty = tmp_path / "empty.xml"
    empty.write_text(NO_INTESTINE)
    baseline = subprocess.Popen([sys.executable, "-m", "viscera", "view", str(empty)], env=environment(display),
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    panels, _ = watch(display, baseline, lambda count: count > 1000)  # the panels are drawn
    err = stop(baseline)
    assert panels > 1000 and "Traceback" not in err, err
    viewer = subprocess.Popen([sys.executable, "-m", "viscera", "view", str(ABDOMEN)], env=environment(display),
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    count, screen = watch(display, viewer, lambda count: count > panels + 500)
    alive = viewer.poll() is None
    err = stop(viewer)
    from PIL import Image
    Image.fromarray(screen.astype(np.uint8)).save(tmp_path / "viewer.png")  # for a person to look at
    assert alive, err
    assert count > panels + 500, (count, panels)
    assert "Traceback" not in err, err


def test_launch_passive_after_import_viscera_draws_the_intestine(display):
    """The documented Python route: import viscera (the plugin registers), load an MJCF scene,
    mujoco.viewer.launch_passive, step and sync; without panels every pink pixel is the bowel."""
    script = f"""
import sys, threading
import viscera
import mujoco, mujoco.viewer
model = mujoco.MjModel.from_xml_path({str(ABDOMEN)!r})
data = mujoco.MjData(model)
before = set(threading.enumerate())
with mujoco.viewer.launch_passive(model, data, show_left_ui=False, show_right_ui=False) as viewer:
    with viewer.lock():  # into the cavity from above the feet
        viewer.cam.lookat[:] = (0.0, 0.0, 0.03)
        viewer.cam.distance, viewer.cam.azimuth, viewer.cam.elevation = 0.45, 90.0, -60.0
    for _ in range(50):
        mujoco.mj_step(model, data)
        viewer.sync()
    print("synced", flush=True)
    sys.stdin.read()  # until the test closes it
for thread in set(threading.enumerate()) - before:
    thread.join()  # the viewer's own thread closes its window: exiting first can crash Mesa (docs/pixels.md)
"""
    process = subprocess.Popen([sys.executable, "-c", script], env=environment(display), stdin=subprocess.PIPE,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert process.stdout.readline().strip() == "synced", process.stderr.read()
    count, _ = watch(display, process, lambda count: count > 20000)
    _, err = process.communicate(input="", timeout=60)
    assert count > 20000, count
    assert process.returncode == 0 and "Traceback" not in err, err


def test_the_documented_passive_viewer_snippet_runs(display):
    """docs/pixels.md's launch_passive snippet, as written, on the virtual display: 10 simulated
    seconds in the viewer, then a clean exit."""
    import re
    page = (ROOT / "docs" / "pixels.md").read_text()
    code = next(block for block in re.findall(r"```python\n(.*?)```", page, re.S) if "launch_passive" in block)
    done = subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=environment(display), capture_output=True,
                          text=True, timeout=300)
    assert done.returncode == 0 and "Traceback" not in done.stderr, done.stderr


def test_view_opens_from_the_scenes_first_camera(display, tmp_path):
    """With the abdomen's `top` camera first, the bowel fills the view (about a third of the screen
    is its colour); MuJoCo's own default view of the whole scene shows it a few centimetres wide."""
    scene = tmp_path / "top_first.xml"
    text = ABDOMEN.read_text()
    overview = next(line for line in text.splitlines() if 'name="overview"' in line)
    scene.write_text(text.replace(overview + "\n", ""))
    viewer = subprocess.Popen([sys.executable, "-m", "viscera", "view", str(scene)], env=environment(display),
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    count, _ = watch(display, viewer, lambda count: count > 150_000)
    err = stop(viewer)
    assert count > 150_000, (count, err)
