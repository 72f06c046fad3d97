"""teleop's own window: the laparoscope's view drawn by MuJoCo's renderer in a GLFW window (the
binding the mujoco wheel installs), whose key callback reports presses and releases, so that a
held key moves a tool smoothly at its velocity limits (devices.HeldKeyboardDevice).

MuJoCo's interactive viewer reports key presses only, without repeats or releases (the keyboard
then steps: `teleop --keys step`). This window draws what the viewer would, through the
laparoscope: the model's own scene (the plugin draws the intestine into it), the overlay's text
boxes (app.overlay) with MuJoCo's fonts; it has no panels and no mouse perturbation. It runs on
the main thread (GLFW's events must), the session on another (Session.run, holding `lock` for
each tick): a frame reads the data between ticks and never holds the simulation up for longer
than MuJoCo takes to fill its scene.
"""

from __future__ import annotations

import threading

import mujoco

from viscera.cli import UserError
from viscera.teleop.session import FRAME_S, Session

SIZE = (960, 720)      # pixels: a monitor's 4:3 (the renderer widens the view, fovy is vertical)
TITLE = "viscera teleop"


class Window:
    """The session's view and its keyboard (see the module doc)."""

    def __init__(self, session: Session, on_key, lock: threading.Lock, title: str = TITLE):
        import glfw
        self.glfw, self.session, self.lock = glfw, session, lock
        if not glfw.init():
            raise UserError("teleop: GLFW cannot open a window on this display", status=2)
        glfw.window_hint(glfw.SAMPLES, 0)  # software GL: no multisampling
        self.window = glfw.create_window(SIZE[0], SIZE[1], title, None, None)
        if not self.window:
            glfw.terminate()
            raise UserError("teleop: GLFW cannot open a window on this display", status=2)
        glfw.make_context_current(self.window)
        glfw.swap_interval(0)
        model = session.model
        self.context = mujoco.MjrContext(model, mujoco.mjtFontScale.mjFONTSCALE_150)  # the overlay's font
        self.scene = mujoco.MjvScene(model, maxgeom=10_000)
        self.camera = mujoco.MjvCamera()
        laparoscope = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, "laparoscope")
        if laparoscope >= 0:
            self.camera.type = mujoco.mjtCamera.mjCAMERA_FIXED
            self.camera.fixedcamid = laparoscope
        else:
            mujoco.mjv_defaultFreeCamera(model, self.camera)
        self.option = mujoco.MjvOption()
        self.frames = 0
        glfw.set_key_callback(self.window, lambda window, key, scancode, action, mods: on_key(key, action))

    def open(self) -> bool:
        return not self.glfw.window_should_close(self.window)

    def draw(self, texts_of) -> None:
        """One frame: the scene and `texts_of(session)`'s boxes, filled between two ticks."""
        with self.lock:
            mujoco.mjv_updateScene(self.session.model, self.session.data, self.option, None, self.camera,
                                   mujoco.mjtCatBit.mjCAT_ALL, self.scene)
            texts = texts_of(self.session)
        width, height = self.glfw.get_framebuffer_size(self.window)
        viewport = mujoco.MjrRect(0, 0, width, height)
        mujoco.mjr_render(viewport, self.scene, self.context)
        for font, grid, left, right in texts:
            mujoco.mjr_overlay(font, grid, viewport, left, right, self.context)
        self.glfw.swap_buffers(self.window)
        self.glfw.poll_events()
        self.frames += 1

    def run(self, texts_of) -> "SessionResult":  # noqa: F821
        """Run the session on a thread of its own and draw it here until it ends or the window closes."""
        results = []
        failures = []
        alive = threading.Event()
        alive.set()

        def simulate():
            try:
                results.append(self.session.run(on_frame=lambda _: alive.is_set(), lock=self.lock))
            except BaseException as error:  # noqa: BLE001 (shown on the main thread)
                failures.append(error)

        thread = threading.Thread(target=simulate, name="viscera-teleop-session", daemon=True)
        thread.start()
        try:
            while thread.is_alive():
                if not self.open():
                    alive.clear()
                self.draw(texts_of)
                thread.join(FRAME_S)
        except KeyboardInterrupt:
            alive.clear()
            thread.join()
        if failures:
            raise failures[0]
        return results[0]

    def close(self) -> None:
        self.context.free()
        self.glfw.destroy_window(self.window)
        self.glfw.terminate()
