"""`python -m viscera teleop TASK`: a task seen through the laparoscope, in teleop's own window
(viscera.teleop.window: held keys) or MuJoCo's viewer (--keys step, the other devices), its
tools and the scope driven by a person, with an overlay (the bindings, the active tool, each tool's force,
the time, falling behind real time, and a warning while a tissue threshold is crossed); the
score is printed when the episode ends (success, failure, time limit, or the window closed).

The viewer's mouse perturbation is switched off (its forces would not be in the recording,
which must replay bit for bit), and so are its panels (Tab shows them).
"""

from __future__ import annotations

import os
import sys
import threading

import mujoco
import numpy as np

from viscera import assess
from viscera.cli import UserError
from viscera.teleop import devices, make as make_device
from viscera.teleop.session import FRAME_S, Session

OVERLAY_FONT = mujoco.mjtFontScale.mjFONTSCALE_150


def check_display() -> None:
    if sys.platform.startswith("linux") and not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY"):
        raise UserError("teleop needs a display (DISPLAY is not set): run it on a desktop, or under a virtual "
                        "display such as xvfb-run", status=2)


def overlay(session: Session) -> list[tuple]:
    """The viewer's text boxes: (font, grid position, left column, right column)."""
    device = session.device
    snapshot = session.snapshot()
    keys = device.help_lines() if device is not None else []
    names, values = ["active tool"], [device.active_tool or "-" if device else "-"]
    for tool in session.tools:
        force = float(np.linalg.norm(snapshot.tissue_force[tool.name]))
        names.append(f"{tool.name} force")
        values.append(f"{force:5.2f} N" + (f"  holding, pinch {snapshot.pinch.get(tool.name, 0.0):.1f} N"
                                           if snapshot.holding[tool.name] else ""))
    worst, _, torn = assess.damage_summary(session.physics.intestine(), session.data)
    names.append("bowel wall")
    values.append(f"bruise {worst:.2f} of 1" + (f", PERFORATED ({len(torn)})" if torn else ""))
    names += ["time", "behind real time"]
    values += [f"{session.data.time:5.1f} / {session.time_limit_s:.0f} s",
               f"{session.ticks_behind} tick{'s' * (session.ticks_behind != 1)}, {session.lost_s:.2f} s lost"]
    boxes = [(OVERLAY_FONT, mujoco.mjtGridPos.mjGRID_TOPRIGHT, "\n".join(names), "\n".join(values))]
    if keys:
        boxes.append((OVERLAY_FONT, mujoco.mjtGridPos.mjGRID_TOPLEFT, "\n".join(k for k, _ in keys),
                      "\n".join(v for _, v in keys)))
    warnings = []
    for name in snapshot.warning:
        force = float(np.linalg.norm(snapshot.tissue_force[name]))
        if force > assess.TRACTION_LIMIT_N:
            warnings.append(f"{name}: {force:.1f} N on the tissue, over its {assess.TRACTION_LIMIT_N:g} N limit")
        if session.hold_force_time.get(name, 0.0) > assess.FORCE_TIME_PRODUCT_LIMIT_NS:
            warnings.append(f"{name}: this hold's force-time product {session.hold_force_time[name]:.0f} N s, over "
                            f"{assess.FORCE_TIME_PRODUCT_LIMIT_NS:g} N s")
        if snapshot.pinch.get(name, 0.0) > assess.PERFORATION_PINCH_N:
            warnings.append(f"{name}: pinch {snapshot.pinch[name]:.1f} N, over perforation "
                            f"({assess.PERFORATION_PINCH_N:g} N)")
    if warnings:
        boxes.append((OVERLAY_FONT, mujoco.mjtGridPos.mjGRID_BOTTOMLEFT, "WARNING", "\n".join(warnings)))
    return boxes


def prepare_view(model: mujoco.MjModel) -> None:
    """The viewer opens through the laparoscope, its light on (a scope lights what it sees), and
    draws cheaply: no shadows and coarser curved surfaces (software GL draws a frame of the
    abdomen in about a second with them). Drawing settings only: the physics is the same."""
    camera = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, "laparoscope")
    model.vis.global_.cameraid = camera if camera >= 0 else (0 if model.ncam else -1)
    light = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_LIGHT, "laparoscope_light")
    if light >= 0:
        model.light_active[light] = 1
    model.light_castshadow[:] = 0
    model.vis.quality.numslices, model.vis.quality.numstacks = 12, 6


class Display(threading.Thread):
    """Shows the session in MuJoCo's passive viewer, apart from the simulation's thread: the
    viewer's calls wait for its render thread (a frame can take a second in software GL), and
    the simulation must never wait for a frame. Under `lock`, between ticks, it copies the data
    to the viewer and clears the viewer's perturbation forces (they would not be in the
    recording, which must replay bit for bit); the overlay's texts go out after."""

    def __init__(self, viewer, session: Session, lock: threading.Lock):
        super().__init__(name="viscera-teleop-display", daemon=True)
        self.viewer, self.session, self.lock = viewer, session, lock
        self.stop = threading.Event()
        self.frames = 0

    def run(self) -> None:
        camera = self.session.model.vis.global_.cameraid
        if camera >= 0:  # the viewer's first frame aligns a free camera: look through the scope after it
            with self.viewer.lock():
                self.viewer.cam.type = mujoco.mjtCamera.mjCAMERA_FIXED
                self.viewer.cam.fixedcamid = camera
        while not self.stop.is_set() and self.viewer.is_running():
            with self.lock:
                self.viewer.sync()
                self.session.data.xfrc_applied[:] = 0.0
                texts = overlay(self.session)
            self.viewer.set_texts(texts)  # returns once the viewer has drawn the previous texts
            self.frames += 1
            self.stop.wait(FRAME_S)


def teleop(task: str, seed: int | None = None, device: str = "keyboard", record: str | None = None,
           port: int | None = None, time_limit_s: float | None = None, scene: str = "abdomen", camera: str = "steer",
           optics_deg: float = 0.0, keys: str = "hold", haptic_cpu: int | None = None) -> dict:
    """Run one rehearsal episode in MuJoCo's viewer; print the score and the verdict; return the score."""
    import viscera.tasks
    if task not in viscera.tasks.ALL:
        raise UserError(f"unknown task {task!r}; known: {', '.join(viscera.tasks.ALL)}", status=2)
    check_display()
    # Mesa's software GL (no GPU) would draw on every core; on one, the simulation keeps the other
    os.environ.setdefault("LP_NUM_THREADS", "1")
    try:
        hardware = (devices.HeldKeyboardDevice() if device == "keyboard" and keys == "hold"
                    else make_device(device, port, haptic_cpu))
    except devices.DeviceError as error:
        raise UserError(str(error), status=2) from None
    session = None
    try:
        session = Session(task, seed=seed, device=hardware, time_limit_s=time_limit_s, scene=scene, camera=camera,
                          optics_deg=optics_deg)
        prepare_view(session.model)
        scope = {"steer": f", and the laparoscope ({optics_deg:g} degree optics) as its last tool",
                 "follow": f"; the laparoscope ({optics_deg:g} degree optics) follows the active tool",
                 "fixed": ""}[camera]
        if isinstance(hardware, devices.HeldKeyboardDevice):  # our own window: key presses and releases
            from viscera.teleop.window import Window
            window = Window(session, hardware.key_event, threading.Lock(), title=f"viscera teleop: {task}")
            print(f"teleop {task} (seed {seed}): the held keys drive the tools{scope}; close the window to stop",
                  flush=True)
            try:
                result = window.run(overlay)
            finally:
                window.close()
            return _finish(session, result, record, task)
        import mujoco.viewer
        key_callback = hardware.key if isinstance(hardware, devices.KeyboardDevice) else None
        lock = threading.Lock()
        before = set(threading.enumerate())
        with mujoco.viewer.launch_passive(session.model, session.data, key_callback=key_callback,
                                          show_left_ui=False, show_right_ui=False) as viewer:
            display = Display(viewer, session, lock)
            display.start()
            print(f"teleop {task} (seed {seed}): the {hardware.name} drives the tools{scope}; close the window to stop",
                  flush=True)
            try:
                result = session.run(on_frame=lambda _: viewer.is_running(), lock=lock)
            finally:
                display.stop.set()
                display.join()
        for thread in set(threading.enumerate()) - before:
            if "_launch_internal" in thread.name:
                thread.join()  # the viewer's thread closes its window: exiting before it can crash Mesa
    finally:
        if session is not None:
            session.close()
        else:
            hardware.close()
    return _finish(session, result, record, task)


def _finish(session: Session, result, record: str | None, task: str) -> dict:
    """Save the recording (with --record), print the score and the verdict."""
    if record and result.recording is not None:
        result.recording.save(record)
        print(f"recording        {record} ({result.ticks} ticks)")
    report(result, task)
    return result.score or {}


def report(result, task: str) -> None:
    """How the session ended, the score, then the verdict line (as record and replay end)."""
    from viscera.recording import verdict
    print(f"ended            {result.ended} after {result.simulated_s:.2f} s; behind real time on "
          f"{result.ticks_behind} of {result.ticks} ticks ({result.lost_s:.2f} s lost)")
    if result.score:
        for line in assess.summary_lines(result.score):
            print(line)
    print(verdict(task, result.success), flush=True)
