"""Shared helpers: small MJCF scenes around one intestine; the checkout's tools importable."""

import pathlib
import sys

import mujoco
import pytest

import viscera

# The tools (benchmarks, validation cases, settle, soak) are not installed with the library:
# they run from the checkout as scripts, and the tests import them from there.
sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[2] / "python" / "tools"))


def scene_xml(body: str = "", options: str = 'timestep="0.002"', name: str = "gut", assets: str = "", **config) -> str:
    """An MJCF model with one intestine (config as keyword arguments), extra worldbody and asset XML."""
    return (f"<mujoco><option {options}/><asset>{assets}</asset>{viscera.extension_xml(name, **config)}"
            f"<worldbody>{body}</worldbody></mujoco>")


def compile_scene(body: str = "", options: str = 'timestep="0.002"', assets: str = "", **config):
    model = mujoco.MjModel.from_xml_string(scene_xml(body, options, assets=assets, **config))
    return model, mujoco.MjData(model), viscera.intestine(model)


@pytest.fixture
def falling_line():
    """A 1 m, 40-point intestine 0.5 m above a plane, tilted, with a free box below one end."""
    body = ('<geom name="floor" type="plane" size="3 3 0.1"/>'
            '<body name="box" pos="0.3 0 0.05"><freejoint/><geom type="box" size="0.05 0.05 0.05" mass="0.1"/></body>')
    return compile_scene(body, length=1.0, control_points=40, shape="line", start=[0.0, 0.0, 0.3],
                         direction=[1.0, 0.0, 0.1])


@pytest.fixture
def display():
    """A virtual X display (Xvfb) for MuJoCo's viewer; Xvfb writes its number to the pipe once it
    serves (-noreset: the server is not regenerated when its last client, a screenshot, leaves)."""
    import os
    import subprocess
    read, write = os.pipe()
    server = subprocess.Popen(["Xvfb", "-displayfd", str(write), "-screen", "0", "1920x1080x24", "-nolisten", "tcp",
                               "-noreset"],
                              pass_fds=(write,), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    os.close(write)
    number = b""
    while not number.endswith(b"\n"):  # the number, then its newline: Xvfb dies if the pipe closes between
        chunk = os.read(read, 32)
        assert chunk, "Xvfb exited before it served"
        number += chunk
    try:
        yield f":{number.decode().strip()}"
    finally:
        server.terminate()
        server.wait(timeout=30)
        os.close(read)
