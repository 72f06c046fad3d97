"""The teleop view with its overlay, as a person sees it, for docs/rehearsal.md.

    python python/tools/teleop_picture.py --out docs/rehearsal/teleop.png [--task clear_area] [--seed 0]

Runs `python -m viscera teleop`'s window (viscera.teleop.window: the laparoscope's view, the
overlay, the held keyboard's bindings) on a virtual X display (Xvfb) with the task's scripted policy
at the controls, and takes a screenshot of the window once the tools are at work (--at
simulated seconds).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import threading


def start_display() -> tuple[subprocess.Popen, str]:
    read, write = os.pipe()
    server = subprocess.Popen(["Xvfb", "-displayfd", str(write), "-screen", "0", "1280x1024x24", "-nolisten", "tcp"],
                              pass_fds=(write,), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    os.close(write)
    number = b""
    while not number.endswith(b"\n"):
        chunk = os.read(read, 32)
        if not chunk:
            raise SystemExit("Xvfb exited before it served")
        number += chunk
    os.close(read)
    return server, f":{number.decode().strip()}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="docs/rehearsal/teleop.png")
    parser.add_argument("--task", default="clear_area")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--at", type=float, default=6.0, help="simulated seconds before the screenshot")
    args = parser.parse_args()
    server, display = start_display()
    os.environ["DISPLAY"] = display
    os.environ.pop("MUJOCO_GL", None)
    os.environ.setdefault("LP_NUM_THREADS", "1")
    try:
        from PIL import ImageGrab

        import viscera.tasks
        from viscera.teleop import app
        from viscera.teleop.devices import HeldKeyboardDevice, PolicyDevice
        from viscera.teleop.session import FRAME_S, Session
        from viscera.teleop.window import Window

        device = PolicyDevice()
        device.help_lines = HeldKeyboardDevice().help_lines  # the overlay a keyboard user sees
        session = Session(args.task, seed=args.seed, device=device, record=False)
        device.drive(session, viscera.tasks.scripted_policy(session.env))
        app.prepare_view(session.model)
        lock = threading.Lock()
        window = Window(session, lambda key, action: None, lock, title=f"viscera teleop: {args.task}")
        try:
            thread = threading.Thread(target=session.run, kwargs={"duration_s": args.at, "lock": lock})
            thread.start()
            while thread.is_alive():
                window.draw(app.overlay)
                thread.join(FRAME_S)
            window.draw(app.overlay)  # the last tick's state, drawn twice: the window is current
            window.draw(app.overlay)
            ImageGrab.grab(xdisplay=display).crop(window_box(display)).save(args.out)
        finally:
            window.close()
        print(f"wrote {args.out}")
    finally:
        server.terminate()
        server.wait(timeout=30)


def window_box(display: str) -> tuple[int, int, int, int]:
    """teleop's window's box on the screen (left, top, right, bottom)."""
    env = dict(os.environ, DISPLAY=display)
    window = subprocess.run(["xdotool", "search", "--limit", "1", "--name", "viscera teleop"], env=env, capture_output=True,
                            text=True, check=True).stdout.split()[0]
    geometry = dict(line.split("=") for line in subprocess.run(
        ["xdotool", "getwindowgeometry", "--shell", window], env=env, capture_output=True, text=True,
        check=True).stdout.split())
    x, y, w, h = (int(geometry[k]) for k in ("X", "Y", "WIDTH", "HEIGHT"))
    return x, y, x + w, y + h


if __name__ == "__main__":
    sys.exit(main())
