"""Input devices for a person driving the tools: one small interface, one class per device.

A device gives, once per control tick, the target of each tool in its trocar coordinates
(pitch deg, yaw deg, depth m, roll deg, jaw deg: viscera.trajectory.COORDINATES), and receives
after each tick a Snapshot of the tools (where they are, the tissue's force on them). The
session (viscera.teleop.session) moves each tool towards its target no faster than
viscera.trajectory.DEFAULT_MAX_VELOCITY, the velocity limits of scripted trajectories.

| device | library (extra) | how it drives |
|---|---|---|
| keyboard | teleop's window (GLFW) | a held key moves one coordinate of the active tool at its limit |
| keyboard, `--keys step` | MuJoCo's viewer (GLFW) | each key press steps one coordinate of the active tool |
| gamepad | pygame (`viscera[gamepad]`) | sticks and triggers set velocities (rate control) |
| spacemouse | pyspacemouse (`viscera[spacemouse]`) | the cap's six axes set velocities (rate control) |
| socket | none (UDP on loopback) | an external haptic device sends poses, reads forces at 1 kHz |

MuJoCo's viewer reports key presses only (no repeats, no releases): there the keyboard steps
(KeyboardDevice). teleop's own window (viscera.teleop.window) reports releases too: a held key
moves the tool until it is let go (HeldKeyboardDevice, rate control like a gamepad's).
"""

from __future__ import annotations

import dataclasses
import os
import threading

import numpy as np

from viscera.trajectory import COORDINATES, DEFAULT_MAX_VELOCITY, TO_SI

MAX_VELOCITY = np.array([DEFAULT_MAX_VELOCITY[c] for c in COORDINATES])  # deg/s, m/s: the tools' limits


class DeviceError(Exception):
    """A device that cannot start (no such hardware, a library missing): one line for the user."""


@dataclasses.dataclass(frozen=True)
class ToolInfo:
    """One tool as a device sees it. Arrays are in COORDINATES order, user units (deg, m)."""

    name: str
    index: int                 # the tool's place in the session's tool list
    kp: np.ndarray             # (5,) the position actuators' stiffness, SI (N m/rad, N/m); 0 where none
    lower: np.ndarray          # (5,) control range, user units
    upper: np.ndarray          # (5,)
    initial: np.ndarray        # (5,) the pose the episode starts from, user units
    has_jaw: bool


@dataclasses.dataclass(frozen=True)
class Snapshot:
    """The tools after a control tick (user units: deg, m; forces N, world frame)."""

    time_s: float                          # simulated time
    q: dict[str, np.ndarray]               # tool -> (5,) joint positions
    qdot: dict[str, np.ndarray]            # tool -> (5,) joint velocities (per s)
    tissue_force: dict[str, np.ndarray]    # tool -> (3,) the intestine's force on the tool
    holding: dict[str, bool]               # tool -> its jaws hold the bowel
    warning: dict[str, bool]               # tool -> a tissue threshold is crossed
    pinch: dict[str, float] = dataclasses.field(default_factory=dict)  # grasper -> its pinch (N, viscera.assess's model)


class Device:
    """The interface every device implements (see the module doc)."""

    name = "device"

    def __init__(self) -> None:
        self.tools: list[ToolInfo] = []
        self.active = 0
        self.switches = 0  # times the person switched the active tool

    @property
    def active_tool(self) -> str | None:
        return self.tools[self.active].name if self.tools else None

    def start(self, tools: list[ToolInfo]) -> None:
        self.tools = list(tools)
        self.active = 0

    def next_tool(self) -> None:
        if self.tools:
            self.active = (self.active + 1) % len(self.tools)
            self.switches += 1

    def targets(self, now_s: float) -> dict[str, np.ndarray]:
        """Each tool's absolute target (user units); tools left out hold their target."""
        raise NotImplementedError

    def feedback(self, snapshot: Snapshot) -> None:
        """The tools after the tick; a device that renders forces keeps it."""

    def help_lines(self) -> list[tuple[str, str]]:
        """(control, what it does) pairs for the viewer's overlay."""
        return []

    def close(self) -> None:
        """Free the hardware; called once the session ends."""


class RateDevice(Device):
    """A device that sets each coordinate's velocity (a fraction of MAX_VELOCITY, in [-1, 1]) for
    the active tool, integrated into targets within the control range; the jaw is set
    absolutely (0 closed, 1 open)."""

    def __init__(self) -> None:
        super().__init__()
        self._targets: dict[str, np.ndarray] = {}
        self._last_s: float | None = None

    def start(self, tools: list[ToolInfo]) -> None:
        super().start(tools)
        self._targets = {t.name: t.initial.copy() for t in tools}
        self._last_s = None

    def read(self) -> tuple[np.ndarray, float | None, bool]:
        """The hardware's state: velocity fractions (5,) (the jaw's entry ignored), the jaw's
        opening fraction (None: unchanged), and whether the switch-tool control was pressed."""
        raise NotImplementedError

    def targets(self, now_s: float) -> dict[str, np.ndarray]:
        rates, jaw, switch = self.read()
        if switch:
            self.next_tool()
        dt = 0.0 if self._last_s is None else max(0.0, now_s - self._last_s)
        self._last_s = now_s
        tool = self.tools[self.active]
        target = self._targets[tool.name]
        rates = np.clip(np.nan_to_num(np.asarray(rates, dtype=float)), -1.0, 1.0)
        target[:4] += rates[:4] * MAX_VELOCITY[:4] * dt
        if jaw is not None and tool.has_jaw:
            target[4] = tool.lower[4] + float(np.clip(jaw, 0.0, 1.0)) * (tool.upper[4] - tool.lower[4])
        np.clip(target, tool.lower, tool.upper, out=target)
        return {name: value.copy() for name, value in self._targets.items()}


# -- keyboard: MuJoCo's viewer passes key presses (GLFW key codes) to a callback

KEY_UP, KEY_DOWN, KEY_LEFT, KEY_RIGHT = 265, 264, 263, 262
KEY_HOME, KEY_END, KEY_INSERT, KEY_DELETE = 268, 269, 260, 261
KEY_ENTER, KEY_PAGE_DOWN = 257, 267
# Keys MuJoCo's viewer leaves alone in passive mode: its letters, digits 0-5, Page Up, Tab,
# Space, [ ] - = and the F keys all have jobs of their own.
KEY_STEPS = {  # key -> (coordinate index, step in user units)
    KEY_UP: (0, 2.0), KEY_DOWN: (0, -2.0),          # pitch (deg): up the laparoscope's image is cranial
    KEY_LEFT: (1, 2.0), KEY_RIGHT: (1, -2.0),       # yaw (deg): positive yaw takes the tip to -x, the image's left
    KEY_HOME: (2, 0.005), KEY_END: (2, -0.005),     # depth (m): Home pushes in
    KEY_INSERT: (3, -15.0), KEY_DELETE: (3, 15.0),  # roll (deg)
}
KEY_NAMES = {KEY_UP: "Up", KEY_DOWN: "Down", KEY_LEFT: "Left", KEY_RIGHT: "Right", KEY_HOME: "Home",
             KEY_END: "End", KEY_INSERT: "Insert", KEY_DELETE: "Delete", KEY_ENTER: "Enter",
             KEY_PAGE_DOWN: "Page Down"}


class KeyboardDevice(Device):
    """Key presses in MuJoCo's viewer step the active tool: arrows pitch and yaw 2 degrees, Home
    and End insert and withdraw 5 mm, Insert and Delete roll 15 degrees, Enter opens or closes
    the jaws, Page Down switches the tool. `key(code)` is the viewer's key callback (it runs on
    the viewer's thread: presses queue under a lock and apply at the next tick)."""

    name = "keyboard"

    def __init__(self) -> None:
        super().__init__()
        self._pressed: list[int] = []
        self._lock = threading.Lock()
        self._targets: dict[str, np.ndarray] = {}
        self.presses = 0  # keys acted on

    def start(self, tools: list[ToolInfo]) -> None:
        super().start(tools)
        self._targets = {t.name: t.initial.copy() for t in tools}

    def key(self, keycode: int) -> None:
        if keycode in KEY_STEPS or keycode in (KEY_ENTER, KEY_PAGE_DOWN):
            with self._lock:
                self._pressed.append(int(keycode))

    def targets(self, now_s: float) -> dict[str, np.ndarray]:
        with self._lock:
            pressed, self._pressed = self._pressed, []
        for keycode in pressed:
            self.presses += 1
            if keycode == KEY_PAGE_DOWN:
                self.next_tool()
                continue
            tool = self.tools[self.active]
            target = self._targets[tool.name]
            if keycode == KEY_ENTER:
                if tool.has_jaw:  # open goes closed, anything else opens
                    middle = 0.5 * (tool.lower[4] + tool.upper[4])
                    target[4] = tool.lower[4] if target[4] > middle else tool.upper[4]
                continue
            index, step = KEY_STEPS[keycode]
            target[index] = float(np.clip(target[index] + step, tool.lower[index], tool.upper[index]))
        return {name: value.copy() for name, value in self._targets.items()}

    def help_lines(self) -> list[tuple[str, str]]:
        return [("Up / Down", "pitch 2 deg"), ("Left / Right", "yaw 2 deg"), ("Home / End", "in / out 5 mm"),
                ("Insert / Delete", "roll 15 deg"), ("Enter", "jaws open / close"),
                ("Page Down", "next tool, then the scope")]


# -- keyboard held: a window of our own (viscera.teleop.window, GLFW) reports presses and releases

KEY_RATES = {  # key -> (coordinate index, direction): held, the coordinate moves at the tools' velocity limit
    KEY_UP: (0, 1.0), KEY_DOWN: (0, -1.0), KEY_LEFT: (1, 1.0), KEY_RIGHT: (1, -1.0),
    KEY_HOME: (2, 1.0), KEY_END: (2, -1.0), KEY_INSERT: (3, -1.0), KEY_DELETE: (3, 1.0),
}
PRESS, RELEASE = 1, 0  # GLFW's key actions (2, a repeat, changes nothing: the key is still held)


class HeldKeyboardDevice(RateDevice):
    """Held keys move the active tool at its velocity limits, released keys stop it: the same
    keys as KeyboardDevice (arrows pitch and yaw, Home and End in and out, Insert and Delete
    roll), Enter opens or closes the jaws and Page Down switches the tool, on their press.
    `key_event(key, action)` is the window's key callback (GLFW's codes and actions; it runs on
    the window's thread: the state is kept under a lock and read at each tick)."""

    name = "keyboard"

    def __init__(self) -> None:
        super().__init__()
        self._held: set[int] = set()
        self._switch = self._toggle = False
        self._lock = threading.Lock()
        self.presses = 0

    def key_event(self, key: int, action: int) -> None:
        with self._lock:
            if action == RELEASE:
                self._held.discard(key)
            elif action == PRESS:
                if key in KEY_RATES:
                    self._held.add(key)
                elif key == KEY_ENTER:
                    self._toggle = True
                elif key == KEY_PAGE_DOWN:
                    self._switch = True
                else:
                    return
                self.presses += 1

    def read(self) -> tuple[np.ndarray, float | None, bool]:
        with self._lock:
            held, switch, toggle = set(self._held), self._switch, self._toggle
            self._switch = self._toggle = False
        rates = np.zeros(5)
        for key in held:
            index, direction = KEY_RATES[key]
            rates[index] += direction
        jaw = None
        if toggle and self.tools:
            tool = self.tools[self.active]
            if tool.has_jaw:  # open goes closed, anything else opens
                jaw = 0.0 if self._targets[tool.name][4] > 0.5 * (tool.lower[4] + tool.upper[4]) else 1.0
        return rates, jaw, switch

    def help_lines(self) -> list[tuple[str, str]]:
        return [("Up / Down (hold)", "pitch"), ("Left / Right (hold)", "yaw"), ("Home / End (hold)", "in / out"),
                ("Insert / Delete (hold)", "roll"), ("Enter", "jaws open / close"),
                ("Page Down", "next tool, then the scope")]


# -- gamepad: pygame (SDL) joysticks

GAMEPAD_DEADZONE = 0.12  # stick travel read as zero: sticks rest a little off centre


def deadzone(value: float, zone: float = GAMEPAD_DEADZONE) -> float:
    """A stick axis with its dead zone removed, rescaled so full travel is still 1."""
    if abs(value) <= zone:
        return 0.0
    return float(np.sign(value) * (abs(value) - zone) / (1.0 - zone))


class GamepadDevice(RateDevice):
    """A gamepad (SDL's standard layout, as pygame reports it): the left stick pitches and yaws
    the active tool, the right stick inserts (up) and rolls, the right trigger closes the jaws as
    far as it is pressed, button A (0) switches the tool. `joystick` is for tests: any object
    with pygame.joystick.Joystick's get_axis, get_button and get_numaxes."""

    name = "gamepad"

    def __init__(self, joystick=None) -> None:
        super().__init__()
        self._pygame = None
        if joystick is None:
            os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")  # pygame greets on stdout otherwise
            try:
                import pygame
            except ImportError:
                raise DeviceError("--device gamepad needs pygame: pip install 'viscera[gamepad]'") from None
            pygame.joystick.init()
            if pygame.joystick.get_count() == 0:
                raise DeviceError("--device gamepad: no gamepad found (pygame sees no joystick)")
            joystick = pygame.joystick.Joystick(0)
            self._pygame = pygame
        self.joystick = joystick
        self._switch_was_down = False

    def read(self) -> tuple[np.ndarray, float | None, bool]:
        if self._pygame is not None:
            self._pygame.event.pump()  # SDL updates joystick state when events are pumped
        axis = self.joystick.get_axis
        count = self.joystick.get_numaxes()
        rates = np.array([-deadzone(axis(1)), -deadzone(axis(0)), -deadzone(axis(3)) if count > 3 else 0.0,
                          deadzone(axis(2)) if count > 2 else 0.0, 0.0])
        jaw = None
        if count > 5:  # right trigger: -1 released (jaws open) to 1 pressed (closed)
            jaw = 1.0 - 0.5 * (axis(5) + 1.0)
        down = bool(self.joystick.get_button(0))
        switch = down and not self._switch_was_down
        self._switch_was_down = down
        return rates, jaw, switch

    def help_lines(self) -> list[tuple[str, str]]:
        return [("left stick", "pitch / yaw"), ("right stick", "in-out / roll"), ("right trigger", "close jaws"),
                ("A", "next tool")]

    def close(self) -> None:
        if self._pygame is not None:
            self._pygame.joystick.quit()


# -- 3Dconnexion SpaceMouse: pyspacemouse (hidapi)

class SpaceMouseDevice(RateDevice):
    """A 3Dconnexion SpaceMouse: push the cap forward/back to pitch, sideways to yaw, down to
    insert (up to withdraw), twist to roll; the left button opens or closes the jaws, the right
    one switches the tool. `mouse` is for tests: any object whose read() returns pyspacemouse's
    state (x, y, z, roll, pitch, yaw in [-1, 1], buttons)."""

    name = "spacemouse"

    def __init__(self, mouse=None) -> None:
        super().__init__()
        self._opened = None
        if mouse is None:
            try:
                import pyspacemouse
            except ImportError:
                raise DeviceError("--device spacemouse needs pyspacemouse: pip install 'viscera[spacemouse]'") from None
            try:  # right-handed, z up: x to the right, y away from the user, z up
                mouse = pyspacemouse.open(axis_convention=pyspacemouse.AxisConvention.HID_Z_UP)
            except Exception as error:  # no device, or hidapi's platform errors: one line
                raise DeviceError(f"--device spacemouse: cannot open a SpaceMouse ({error})") from None
            self._opened = mouse
        self.mouse = mouse
        self._buttons = [0, 0]
        self._jaw_open = True

    def read(self) -> tuple[np.ndarray, float | None, bool]:
        state = self.mouse.read()
        rates = np.array([float(state.y), -float(state.x), -float(state.z), float(state.yaw), 0.0])
        buttons = list(getattr(state, "buttons", [])) + [0, 0]
        pressed = [bool(now) and not bool(before) for now, before in zip(buttons[:2], self._buttons)]
        self._buttons = [int(bool(b)) for b in buttons[:2]]
        if pressed[0]:
            self._jaw_open = not self._jaw_open
        return rates, (1.0 if self._jaw_open else 0.0), pressed[1]

    def start(self, tools: list[ToolInfo]) -> None:
        super().start(tools)
        self._jaw_open = True

    def help_lines(self) -> list[tuple[str, str]]:
        return [("cap fwd / side", "pitch / yaw"), ("cap down / up", "in / out"), ("cap twist", "roll"),
                ("left button", "jaws open / close"), ("right button", "next tool")]

    def close(self) -> None:
        if self._opened is not None:
            try:
                self._opened.close()
            except Exception:  # closing hardware that vanished: nothing left to free
                pass


class PolicyDevice(Device):
    """A policy at the controls (a dm_env policy: time step in, action out), for pictures and
    tests of the person's path: `drive(session, policy)` before the session runs."""

    name = "policy"

    def drive(self, session, policy) -> None:
        self.session, self.policy = session, policy

    def targets(self, now_s: float) -> dict[str, np.ndarray]:
        action = self.policy(self.session.time_step)
        out = {}
        for tool in self.tools:
            if tool.name not in self.session.mapping.actuators:  # the laparoscope: the policy leaves it aimed
                continue
            actuators = np.array(self.session.mapping.actuators[tool.name])
            out[tool.name] = np.where(actuators >= 0, action[np.maximum(actuators, 0)] / TO_SI, 0.0)
        return out


DEVICES = ("keyboard", "gamepad", "spacemouse", "socket")
