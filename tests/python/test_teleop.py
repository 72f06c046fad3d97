"""A person in the loop: the devices' bindings, the session's velocity limits and real-time pacing,
and `python -m viscera teleop` in MuJoCo's real viewer on a virtual display, driven by key
presses from xdotool."""

from __future__ import annotations

import os
import pathlib
import shutil
import subprocess
import sys
import time
import types

import numpy as np
import pytest

import viscera.tasks
import viscera.teleop
from viscera.teleop import devices
from viscera.teleop.devices import MAX_VELOCITY, ToolInfo
from viscera.teleop.session import Session
from viscera.trajectory import COORDINATES

ROOT = pathlib.Path(__file__).resolve().parents[2]


def tool(name: str = "grasper", index: int = 0, has_jaw: bool = True) -> ToolInfo:
    return ToolInfo(name, index, np.array([20.0, 20.0, 400.0, 2.0, 0.5 if has_jaw else 0.0]),
                    np.array([-60.0, -60.0, 0.0, -180.0, 0.0]), np.array([60.0, 60.0, 0.22, 180.0, 40.0 if has_jaw else 0.0]),
                    np.array([0.0, 0.0, 0.0, 0.0, 40.0 if has_jaw else 0.0]), has_jaw)


# -- the devices' bindings

def test_keyboard_steps_the_active_tool_as_bound_and_switches():
    keyboard = devices.KeyboardDevice()
    keyboard.start([tool("grasper", 0), tool("retractor", 1, has_jaw=False)])
    for key in (devices.KEY_HOME, devices.KEY_HOME, devices.KEY_UP, devices.KEY_LEFT, devices.KEY_DELETE,
                devices.KEY_ENTER, 65, 32):  # 'A' and space belong to MuJoCo's viewer: ignored here
        keyboard.key(key)
    targets = keyboard.targets(0.0)
    np.testing.assert_allclose(targets["grasper"], [2.0, 2.0, 0.010, 15.0, 0.0])  # Enter closed the open jaws
    np.testing.assert_array_equal(targets["retractor"], np.zeros(5))
    assert keyboard.presses == 6
    keyboard.key(devices.KEY_PAGE_DOWN)
    keyboard.key(devices.KEY_END)  # withdrawing below 0 stays at the joint's range
    keyboard.key(devices.KEY_ENTER)  # a retractor has no jaw
    targets = keyboard.targets(0.01)
    assert keyboard.active_tool == "retractor" and keyboard.switches == 1
    np.testing.assert_array_equal(targets["retractor"], np.zeros(5))
    np.testing.assert_allclose(targets["grasper"], [2.0, 2.0, 0.010, 15.0, 0.0])


def test_no_binding_is_one_of_mujoco_viewers_own_keys():
    """MuJoCo's viewer gives every letter, the digits 0-5, Space, Tab, Page Up, [ ] - = and the F
    keys a job of its own; a binding on one would also toggle the viewer."""
    taken = set(range(ord("A"), ord("Z") + 1)) | set(range(ord("0"), ord("6"))) | {32, 258, 266, 91, 93, 45, 61}
    taken |= set(range(290, 315))  # F1-F25
    bound = set(devices.KEY_STEPS) | {devices.KEY_ENTER, devices.KEY_PAGE_DOWN}
    assert not bound & taken


class FakeJoystick:
    def __init__(self):
        self.axes = [0.0] * 6
        self.axes[5] = -1.0  # trigger released
        self.buttons = [0] * 4

    def get_axis(self, i):
        return self.axes[i]

    def get_button(self, i):
        return self.buttons[i]

    def get_numaxes(self):
        return len(self.axes)


def test_gamepad_sets_velocities_within_the_tools_limits():
    stick = FakeJoystick()
    pad = devices.GamepadDevice(joystick=stick)
    pad.start([tool("grasper", 0), tool("retractor", 1, has_jaw=False)])
    pad.targets(0.0)
    stick.axes[1] = -1.0   # left stick full up: pitch at its limit's rate
    stick.axes[3] = -0.5   # right stick half up: insert
    stick.axes[0] = 0.05   # inside the dead zone: no yaw
    stick.axes[5] = 1.0    # trigger pressed: jaws closed
    targets = pad.targets(0.5)
    half_travel = (0.5 - devices.GAMEPAD_DEADZONE) / (1.0 - devices.GAMEPAD_DEADZONE)
    np.testing.assert_allclose(targets["grasper"], [0.5 * MAX_VELOCITY[0], 0.0, 0.5 * half_travel * MAX_VELOCITY[2],
                                                    0.0, 0.0])
    stick.buttons[0] = 1
    pad.targets(0.5)
    pad.targets(0.5)  # held: one switch per press
    assert pad.active_tool == "retractor" and pad.switches == 1


def test_spacemouse_maps_the_cap_and_buttons():
    state = types.SimpleNamespace(x=0.0, y=1.0, z=-1.0, roll=0.0, pitch=0.0, yaw=0.0, buttons=[0, 0])
    mouse = types.SimpleNamespace(read=lambda: state)
    device = devices.SpaceMouseDevice(mouse=mouse)
    device.start([tool("grasper", 0)])
    device.targets(0.0)
    targets = device.targets(0.2)
    assert targets["grasper"][0] == pytest.approx(0.2 * MAX_VELOCITY[0])  # cap forward: pitch towards cranial
    assert targets["grasper"][2] == pytest.approx(0.2 * MAX_VELOCITY[2])  # cap down: in
    state.buttons = [1, 0]
    assert device.targets(0.2)["grasper"][4] == 0.0  # the left button closes the open jaws


@pytest.mark.parametrize("name, module, extra", [("gamepad", "pygame", "gamepad"),
                                                 ("spacemouse", "pyspacemouse", "spacemouse")])
def test_a_missing_device_library_names_the_extra(monkeypatch, name, module, extra):
    monkeypatch.setitem(sys.modules, module, None)  # import fails as if not installed
    with pytest.raises(devices.DeviceError) as error:
        viscera.teleop.make(name)
    assert f"viscera[{extra}]" in str(error.value) and "\n" not in str(error.value)


# -- the session

class FixedTargets(devices.Device):
    """Asks for the same targets every tick; optionally slow (its read takes `delay_s`)."""

    name = "fixed"

    def __init__(self, targets: dict, delay_s: float = 0.0):
        super().__init__()
        self.wanted, self.delay_s, self.snapshots = targets, delay_s, []

    def targets(self, now_s):
        if self.delay_s:
            time.sleep(self.delay_s)  # the load of a slow device, not a synchronisation
        return self.wanted

    def feedback(self, snapshot):
        self.snapshots.append(snapshot)


def test_the_session_moves_tools_no_faster_than_the_scripted_limits():
    far = {"grasper": np.array([60.0, -60.0, 0.22, 180.0, 0.0]), "retractor": np.array([np.nan] * 5)}
    device = FixedTargets(far)
    session = Session("clear_area", seed=0, device=device, record=False)
    start = {t.name: t.initial.copy() for t in session.tools}
    for _ in range(10):
        session.tick()
    dt = session.control_timestep_s
    expected = start["grasper"] + np.clip(far["grasper"] - start["grasper"], -10 * MAX_VELOCITY * dt, 10 * MAX_VELOCITY * dt)
    np.testing.assert_allclose(session.command["grasper"], expected)
    np.testing.assert_array_equal(session.command["retractor"], start["retractor"])  # NaN targets never reach MuJoCo
    assert np.all(np.isfinite(session.data.ctrl))
    snapshot = device.snapshots[-1]
    assert snapshot.time_s == pytest.approx(10 * dt)
    np.testing.assert_array_equal(snapshot.tissue_force["grasper"],
                                  session.physics.named.data.sensordata["grasper_force"][:3])


def test_the_session_runs_at_wall_clock_rate_never_faster():
    session = Session("grasp_lift", seed=0, device=FixedTargets({}), record=False)
    start = time.perf_counter()
    result = session.run(duration_s=0.5)
    wall = time.perf_counter() - start
    assert result.ended == "duration" and result.simulated_s == pytest.approx(0.5)
    assert wall >= 0.5 - session.control_timestep_s  # the last tick's deadline is its end


def test_falling_behind_is_counted_and_not_caught_up():
    """A device three times slower than the control period: every tick is late, the lost time is
    dropped, and the simulation stays behind the wall clock rather than racing to catch up."""
    session = Session("grasp_lift", seed=0, device=FixedTargets({}, delay_s=0.03), record=False)
    start = time.perf_counter()
    result = session.run(duration_s=0.2)
    wall = time.perf_counter() - start
    assert result.ticks == 20 and result.ticks_behind == result.ticks
    assert result.lost_s > 0.3 and wall > result.simulated_s + 0.3


# -- the real viewer, on a virtual display, driven by xdotool

needs_display_tools = pytest.mark.skipif(shutil.which("Xvfb") is None or shutil.which("xdotool") is None,
                                         reason="needs Xvfb and xdotool (.ci/run installs them)")


def display_environment(display: str) -> dict:
    env = dict(os.environ, DISPLAY=display, LP_NUM_THREADS="1")  # software GL on one core: the other simulates
    env.pop("MUJOCO_GL", None)
    return env


def teleop_typed(env: dict, options: list[str], first_line: str, window_name: str, keys: list[str]):
    """`python -m viscera teleop clear_area --seed 3 OPTIONS` on the display, its window found by
    name and focused, then xdotool's command KEYS; the process once the episode ends, its output
    and its errors."""
    process = subprocess.Popen([sys.executable, "-m", "viscera", "teleop", "clear_area", "--seed", "3", *options],
                               env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        line = process.stdout.readline()
        assert line.startswith(first_line), line + process.stderr.read()
        window = subprocess.run(["xdotool", "search", "--sync", "--limit", "1", "--name", window_name], env=env,
                                capture_output=True, text=True, timeout=60).stdout.split()[0]
        subprocess.run(["xdotool", "windowfocus", "--sync", window], env=env, check=True, timeout=30)
        subprocess.run(["xdotool", *keys], env=env, check=True, timeout=30)
        out_text, err = process.communicate(timeout=120)
    finally:
        if process.poll() is None:
            process.kill()
    return process, out_text, err


@needs_display_tools
def test_key_presses_in_the_viewer_move_the_active_tool_and_switch_tools(display, tmp_path):
    from viscera.recording import load
    out = tmp_path / "keys.npz"
    env = display_environment(display)
    keys = ["key", "--delay", "30"] + ["Home"] * 4 + ["Up", "Up", "Left", "Return", "Next", "Home", "Home", "Delete"]
    process, out_text, err = teleop_typed(env, ["--keys", "step", "--time-limit", "5", "--record", str(out)],
                                          "teleop clear_area", "MuJoCo", keys)  # the 5 s time limit ends it
    assert process.returncode == 0 and "Traceback" not in err, err
    assert "success: no" in out_text, out_text
    recording = load(out)
    last = recording.actions[-1]
    names = [f"{t}_{c}" for t in ("grasper", "retractor") for c in COORDINATES if not (t == "retractor" and c == "jaw")]
    final = dict(zip(names, last))
    started = viscera.tasks.load("clear_area", seed=3)
    started.reset()
    start = dict(zip(names, started.physics.data.ctrl))  # where the episode starts the tools (in view)
    # the grasper: 4 x 5 mm in, 2 x 2 degrees of pitch, 2 degrees of yaw, jaws closed
    assert final["grasper_depth"] - start["grasper_depth"] == pytest.approx(0.020)
    assert final["grasper_pitch"] - start["grasper_pitch"] == pytest.approx(np.radians(4.0))
    assert final["grasper_yaw"] - start["grasper_yaw"] == pytest.approx(np.radians(2.0))
    assert final["grasper_jaw"] == pytest.approx(0.0)
    # then Page Down: the retractor, 2 x 5 mm in and 15 degrees of roll
    assert final["retractor_depth"] - start["retractor_depth"] == pytest.approx(0.010)
    assert final["retractor_roll"] - start["retractor_roll"] == pytest.approx(np.radians(15.0))
    assert final["retractor_pitch"] == start["retractor_pitch"] and final["grasper_roll"] == start["grasper_roll"]


@needs_display_tools
def test_a_held_key_moves_the_tool_at_its_velocity_limit_until_released(display, tmp_path):
    """teleop's own window (the default keyboard): xdotool holds Home down for 0.6 s, then, after
    Page Down, Up for 0.4 s. The recorded depth command is a ramp at the depth's velocity limit
    for as long as the key was held, then still; the second tool's (the retractor's) pitch ramps
    likewise; the other coordinates never move."""
    from viscera.recording import load
    out = tmp_path / "held.npz"
    env = display_environment(display)
    # the holds' lengths are the input itself (a person holding a key), not a wait for something
    keys = ["keydown", "Home", "sleep", "0.6", "keyup", "Home", "key", "Next", "keydown", "Up", "sleep", "0.4",
            "keyup", "Up"]
    process, out_text, err = teleop_typed(env, ["--time-limit", "6", "--record", str(out)],
                                          "teleop clear_area (seed 3): the held keys drive the tools", "viscera teleop",
                                          keys)
    assert process.returncode == 0 and "Traceback" not in err, err
    recording = load(out)
    names = [f"{t}_{c}" for t in ("grasper", "retractor") for c in COORDINATES if not (t == "retractor" and c == "jaw")]
    actions = dict(zip(names, recording.actions.T))
    dt = recording.control_timestep_s

    def ramp(values: np.ndarray, per_tick: float) -> int:
        """The ticks the value moved: each by exactly per_tick, all in one run."""
        moved = np.nonzero(np.abs(np.diff(values)) > 1e-12)[0]
        assert len(moved) and np.all(np.diff(moved) == 1), moved  # one continuous run, not steps
        np.testing.assert_allclose(np.diff(values)[moved], per_tick, rtol=1e-9)
        return len(moved)

    depth_ticks = ramp(actions["grasper_depth"], MAX_VELOCITY[2] * dt)
    pitch_ticks = ramp(actions["retractor_pitch"], np.radians(MAX_VELOCITY[0]) * dt)
    assert 0.4 <= depth_ticks * dt <= 0.9 and 0.25 <= pitch_ticks * dt <= 0.7, (depth_ticks, pitch_ticks)
    for name in ("grasper_pitch", "grasper_yaw", "grasper_roll", "retractor_depth"):
        assert np.all(actions[name] == actions[name][0]), name


def test_teleop_without_a_display_is_one_line():
    env = dict(os.environ)
    env.pop("DISPLAY", None)
    env.pop("WAYLAND_DISPLAY", None)
    done = subprocess.run([sys.executable, "-m", "viscera", "teleop", "clear_area"], env=env, capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 2
    assert len(done.stderr.strip().splitlines()) == 1 and "display" in done.stderr, done.stderr


def test_pressing_the_bowel_into_the_wall_raises_the_overlays_warning():
    """The grasper drawn back up its shaft, pointed at a loop of bowel lying on the posterior wall,
    then driven down the shaft 3 cm below it: the tissue's force on it passes the traction limit,
    the snapshot warns and the overlay says so; a hold's force-time product past its limit warns
    too. (Driven there straight from where the episode starts it, in view, the tip sweeps the
    loop aside instead of pressing it.)"""
    from viscera import assess
    from viscera.tasks.policies import Tools
    from viscera.teleop import app
    session = Session("grasp_lift", seed=0, device=None, record=False)
    tools = Tools(session.env)
    lowest = session.physics.axis_points(100)
    reachable = [p for p in lowest if np.linalg.norm(p[:2] - tools.trocar["grasper"][:2]) < 0.05]
    point = min(reachable, key=lambda p: p[2]) - np.array([0.0, 0.0, 0.03])
    goal = tools.coordinates("grasper", point, jaw=40.0)
    pressing = np.array([goal[c] for c in COORDINATES])
    session.device = FixedTargets({"grasper": np.where(np.array(COORDINATES) == "depth", 0.0, pressing)})
    session.device.start(session.tools)
    while session.data.time < 1.5:  # up the shaft, and pointed at the loop
        session.tick()
    session.device.wanted = {"grasper": pressing}
    warned = False
    while not warned and session.data.time < 6.0:
        session.tick()
        warned = session.device.snapshots[-1].warning["grasper"]
    assert warned
    force = np.linalg.norm(session.device.snapshots[-1].tissue_force["grasper"])
    assert force > assess.TRACTION_LIMIT_N
    texts = app.overlay(session)
    assert any(box[2] == "WARNING" and "grasper" in box[3] and "limit" in box[3] for box in texts)
    session.hold_force_time["grasper"] = assess.FORCE_TIME_PRODUCT_LIMIT_NS + 1.0
    assert any("force-time product" in box[3] for box in app.overlay(session))
