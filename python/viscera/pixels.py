"""Pixel observations: RGB, depth and segmentation from one camera, cheap enough to learn from.

    camera = viscera.pixels.Camera(width=84, height=84, camera="laparoscope")
    frame = camera.render(physics)  # {"pixels": (H, W, 3) uint8, "depth": (H, W) float32 m,
                                    #  "segmentation": (H, W) uint8 labels}
    camera.close()

On a machine without a GPU (Mesa's llvmpipe behind EGL or OSMesa) a frame's cost is geometry, not
pixels: the shipped abdomen costs 350 to 510 ms per 84 x 84 RGB frame with MuJoCo's defaults
(python/tools/bench_pixels.py). A Camera renders with the settings observations need, set in its own MuJoCo rendering
context (a human's `physics.render` or viewer keeps the model's):
- capsules tessellated 8 x 4 instead of 28 x 16 (a capsule 12 pixels wide shows no facets);
- no multisampling, no shadows, no reflections;
- one scene update, then two draws: RGB and depth read back together, then the segmentation.
The intestine draws as many capsules as its `draw_capsules` key says (viscera.tasks draws 160,
1.9 cm each, for pixel observations): that, not the pixels, sets the cost. A camera that carries
lights (the laparoscope) is lit by them alone, on even where the model has them off; a camera on
the world body keeps the scene's lighting.

Labels (`segmentation`): 0 nothing of the below (walls, background), 1 the intestine (the plugin's
geoms), 2 a tool (any geom or site of a body under a trocar), 3 the target patch (site
`target_area`), 4 damaged bowel wall (fully bruised or torn: the plugin marks the capsules it draws
there, docs/model.md#damage). MuJoCo's segmentation ignores transparency: a translucent wall in front of the
camera labels every pixel behind it as the wall, hence the laparoscope inside the cavity.

Depth is the distance along the camera's axis (m), as MuJoCo's depth rendering gives, from the
depth buffer and the model's clip planes (`visual/map` znear and zfar, times the extent).

Each Camera has its own OpenGL context (mujoco.GLContext: EGL, OSMesa or GLFW after MUJOCO_GL)
kept current on a thread of its own that makes every GL call, whichever thread renders: an EGL
context can be current on one thread only, and dm_control's EGL contexts stay on the thread that
made them. `close()` frees the contexts and ends the thread (also done at garbage collection and
at exit); a pickled or copied Camera keeps its settings and makes new ones when it next renders.
"""

from __future__ import annotations

import atexit
import concurrent.futures
import os
import queue
import threading
import weakref

import mujoco
import numpy as np

LABELS = {"nothing": 0, "intestine": 1, "tool": 2, "target": 3, "damaged": 4}
DRAWN_DAMAGED = 1          # the plugin's dataid on a capsule over damaged wall (plugin/mujoco/intestine.h)
SLICES, STACKS = 8, 4      # capsule tessellation for observations (MuJoCo's default: 28 x 16)


def _context_class():
    """MuJoCo's GL context class for MUJOCO_GL as it is now (mujoco.GLContext was fixed when
    MuJoCo was imported, perhaps before `import viscera` chose EGL for a machine without a
    display)."""
    backend = os.environ.get("MUJOCO_GL") or ("glfw" if os.environ.get("DISPLAY") else "egl")
    if backend == "egl":
        from mujoco.egl import GLContext
    elif backend == "osmesa":
        from mujoco.osmesa import GLContext
    elif backend == "glfw":
        from mujoco.glfw import GLContext
    else:
        raise ValueError(f"MUJOCO_GL = {backend!r}: must be egl, osmesa or glfw")
    return GLContext


_LIVE: weakref.WeakSet = weakref.WeakSet()  # GL threads not yet freed
_EXIT_HOOK: list = []


def _free_all() -> None:
    """At exit, before MuJoCo's EGL module terminates its display (an atexit hook it registers
    when it makes its first context, before this one is registered, so run after it): free every
    camera's contexts still open."""
    for gl in list(_LIVE):
        gl.free()


class _GLThread:
    """A daemon thread holding one OpenGL context current and making every call on it. Daemon:
    interpreter shutdown joins the other threads before the atexit hooks run, and the hook that
    frees a Camera left open still needs this thread."""

    def __init__(self, width: int, height: int):
        self._jobs: queue.SimpleQueue = queue.SimpleQueue()
        self._thread = threading.Thread(target=self._serve, name="viscera-camera", daemon=True)
        self._thread.start()
        self.context = None  # the MuJoCo rendering context (mujoco.MjrContext), made on this thread
        self.closed = False      # the thread has ended: calls are refused
        self._closing = False    # a free has begun
        self._state = threading.RLock()
        try:
            self._gl = self.call(self._make_current, width, height)
        except BaseException:  # no GL context: the thread ends with it
            self.closed = self._closing = True
            self._jobs.put(None)
            self._thread.join()
            raise
        _LIVE.add(self)
        if not _EXIT_HOOK:  # after the backend's first context: atexit runs the later hook first
            _EXIT_HOOK.append(atexit.register(_free_all))

    @staticmethod
    def _make_current(width: int, height: int):
        gl = _context_class()(width, height)
        gl.make_current()
        return gl

    def _serve(self) -> None:
        while True:
            job = self._jobs.get()
            if job is None:
                return
            future, function, args = job
            if future.set_running_or_notify_cancel():
                try:
                    future.set_result(function(*args))
                except BaseException as error:  # the caller's thread raises it
                    future.set_exception(error)

    def call(self, function, *args):
        if threading.current_thread() is self._thread:  # e.g. a finalizer run by a collection on it
            return function(*args)
        if self.closed:  # a job queued behind the end would wait forever
            raise RuntimeError("the camera's GL thread has ended (freed at exit or closed)")
        future: concurrent.futures.Future = concurrent.futures.Future()
        self._jobs.put((future, function, args))
        return future.result()

    def free(self) -> None:
        """Free the MuJoCo and OpenGL contexts on this thread, then end it."""
        # the first caller frees, any other returns at once: no lock is held while waiting, since a
        # collection on the GL thread may run another camera's finalizer, or this one's
        with self._state:
            if self._closing:
                return
            self._closing = True
        _LIVE.discard(self)
        try:
            self.call(self._free_contexts)
        finally:
            self.closed = True
            self._jobs.put(None)
            if threading.current_thread() is not self._thread:
                self._thread.join()

    def _free_contexts(self) -> None:
        if self.context is not None:
            self.context.free()
            self.context = None
        self._gl.free()


class Camera:
    """RGB, depth and segmentation of a physics' camera; see the module doc."""

    def __init__(self, width: int = 84, height: int = 84, camera: str = "laparoscope"):
        for name, value in (("width", width), ("height", height)):
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not 1 <= value <= 4096:
                raise ValueError(f"{name} = {value!r}: must be an integer from 1 to 4096 (pixels)")
        if not isinstance(camera, str) or not camera:
            raise ValueError(f"camera = {camera!r}: must be the name of a camera of the scene")
        self.width, self.height, self.camera = int(width), int(height), camera
        self._lock = threading.Lock()  # one frame at a time per camera
        self._reset_context()

    def _reset_context(self) -> None:
        self._gl: _GLThread | None = None
        self._model = None       # the model last prepared for (a reload replaces it)
        self._assets = None      # what the MuJoCo context holds of it (_assets)
        self._finalizer = None
        self._scene = None

    # -- pickling and copying: the settings, not the GL state
    def __getstate__(self) -> dict:
        return {"width": self.width, "height": self.height, "camera": self.camera}

    def __setstate__(self, state: dict) -> None:
        self.__init__(**state)

    def close(self) -> None:
        """Free the OpenGL and MuJoCo rendering contexts now (a later render makes new ones)."""
        with self._lock:
            if self._finalizer is not None:
                self._finalizer()
            self._reset_context()

    def _prepare(self, model: mujoco.MjModel) -> None:
        """Make the contexts for `model` (a scene with its own tools: each episode's rebuild makes
        a new model), with the observation settings."""
        if self._gl is not None and self._gl.closed:  # freed at exit: new contexts
            self._reset_context()
        if self._model is model:
            return
        camera_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, self.camera)
        if camera_id < 0:
            names = [model.camera(i).name for i in range(model.ncam)]
            raise ValueError(f"camera = {self.camera!r}: the scene has no such camera; it has {names}")
        if self._gl is None:  # one GL context for the camera's life
            self._gl = _GLThread(self.width, self.height)
            self._finalizer = weakref.finalize(self, self._gl.free)
        assets = _assets(model)
        if assets is None or assets != self._assets:  # else the last context draws this model too
            self._make_context(model)
            self._assets = assets
        if self._scene is None or assets is None or self._scene.maxgeom < model.ngeom + model.nsite + 1024:
            self._scene = mujoco.MjvScene(model, maxgeom=model.ngeom + model.nsite + 4096)
            self._scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = 0
            self._scene.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = 0
            self._scene.flags[mujoco.mjtRndFlag.mjRND_SKYBOX] = 0
        self._model = model
        self._option = mujoco.MjvOption()
        self._mjv_camera = mujoco.MjvCamera()
        self._mjv_camera.type = mujoco.mjtCamera.mjCAMERA_FIXED
        self._mjv_camera.fixedcamid = camera_id
        self._viewport = mujoco.MjrRect(0, 0, self.width, self.height)
        # a camera that carries its own light (a laparoscope) is lit by it alone, on even where the
        # model has it off (for people's views), plus the headlight's ambient as a dim fill: the
        # scene's other lights would shine through the walls
        body = model.cam_bodyid[camera_id]
        own = [i for i in range(model.nlight) if model.light_bodyid[i] == body] if body != 0 else []
        self._lights = own or None  # a camera on the world body carries no light: the scene's lighting
        # label of each model geom and site: a tool's bodies hang under its trocar (a world child)
        tools = {model.body(f"{t}_trocar").id for t in _tool_names(model)}
        self._geom_label = np.where(np.isin(model.body_rootid[model.geom_bodyid], list(tools)),
                                    LABELS["tool"], LABELS["nothing"]).astype(np.uint8)
        self._site_label = np.where(np.isin(model.body_rootid[model.site_bodyid], list(tools)),
                                    LABELS["tool"], LABELS["nothing"]).astype(np.uint8)
        target = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, "target_area")
        if target >= 0:
            self._site_label[target] = LABELS["target"]
        self._rgb = np.empty((self.height, self.width, 3), np.uint8)
        self._depth = np.empty((self.height, self.width), np.float32)
        self._ids = np.empty((self.height, self.width, 3), np.uint8)

    def _make_context(self, model: mujoco.MjModel) -> None:
        """A MuJoCo rendering context for `model` with the observation settings (30 ms)."""
        quality, offscreen = model.vis.quality, model.vis.global_
        saved = (quality.numslices, quality.numstacks, quality.offsamples, offscreen.offwidth, offscreen.offheight)
        quality.numslices, quality.numstacks, quality.offsamples = SLICES, STACKS, 0
        offscreen.offwidth, offscreen.offheight = self.width, self.height
        try:
            self._gl.call(self._replace_context, model)
        finally:  # the model's own settings back: human renders keep them
            (quality.numslices, quality.numstacks, quality.offsamples, offscreen.offwidth,
             offscreen.offheight) = saved

    def _replace_context(self, model: mujoco.MjModel) -> None:
        """On the GL thread: the last model's context freed, this one's made."""
        gl = self._gl
        if gl.context is not None:
            gl.context.free()
            gl.context = None
        gl.context = mujoco.MjrContext(model, mujoco.mjtFontScale.mjFONTSCALE_100)
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, gl.context)

    def _draw(self) -> None:
        """On the GL thread: the RGB and depth draw, then the segmentation draw, read back."""
        scene, context = self._scene, self._gl.context
        mujoco.mjr_render(self._viewport, scene, context)
        mujoco.mjr_readPixels(self._rgb, self._depth, self._viewport, context)
        scene.flags[mujoco.mjtRndFlag.mjRND_SEGMENT] = 1
        scene.flags[mujoco.mjtRndFlag.mjRND_IDCOLOR] = 1
        try:
            mujoco.mjr_render(self._viewport, scene, context)
            mujoco.mjr_readPixels(self._ids, None, self._viewport, context)
        finally:
            scene.flags[mujoco.mjtRndFlag.mjRND_SEGMENT] = 0
            scene.flags[mujoco.mjtRndFlag.mjRND_IDCOLOR] = 0

    def _draw_rgb(self) -> None:
        """On the GL thread: the RGB draw alone, read back."""
        mujoco.mjr_render(self._viewport, self._scene, self._gl.context)
        mujoco.mjr_readPixels(self._rgb, None, self._viewport, self._gl.context)

    def render_rgb(self, physics) -> np.ndarray:
        """The RGB of one frame of `physics` (as `render`), without the depth and segmentation:
        one draw instead of two (a video's frames; gymnasium's render())."""
        model, data = physics if isinstance(physics, tuple) else (physics.model.ptr, physics.data.ptr)
        with self._lock:
            self._prepare(model)
            self._update(model, data)
            self._gl.call(self._draw_rgb)
            return np.flipud(self._rgb).copy()

    def render(self, physics) -> dict[str, np.ndarray]:
        """One frame of `physics` (dm_control Physics, or anything with `.model.ptr` and
        `.data.ptr`, or a (mujoco.MjModel, mujoco.MjData) pair): fresh arrays."""
        model, data = physics if isinstance(physics, tuple) else (physics.model.ptr, physics.data.ptr)
        with self._lock:
            self._prepare(model)
            scene = self._scene
            self._update(model, data)
            self._gl.call(self._draw)
            return self._arrays(model, scene)

    def _update(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """The scene of this frame; a camera that carries lights is lit by them alone (on even
        where the model has them off, for people's views), the headlight kept as ambient fill."""
        scene = self._scene
        mujoco.mjv_updateScene(model, data, self._option, None, self._mjv_camera, mujoco.mjtCatBit.mjCAT_ALL, scene)
        if self._lights is None:
            return
        # keep the headlight only (mjv_makeLights puts it first), without its diffuse and specular parts
        kept = int(scene.nlight > 0 and bool(scene.lights[0].headlight))
        if kept:
            scene.lights[0].diffuse[:] = 0.0
            scene.lights[0].specular[:] = 0.0
        for i in self._lights:  # the camera's own, from the model and this state, not the model's on/off
            if kept >= len(scene.lights):
                break
            _model_light(scene.lights[kept], model, data, i)
            kept += 1
        scene.nlight = kept

    def _arrays(self, model: mujoco.MjModel, scene: mujoco.MjvScene) -> dict[str, np.ndarray]:
        """The frame read back, as the observations' arrays: fresh, top row first."""
        labels = self._labels(model, scene)
        extent = model.stat.extent
        near, far = model.vis.map.znear * extent, model.vis.map.zfar * extent
        depth = near / (1.0 - self._depth * (1.0 - near / far))  # metres along the camera's axis
        segid = (self._ids[..., 0].astype(np.int32) | (self._ids[..., 1].astype(np.int32) << 8)
                 | (self._ids[..., 2].astype(np.int32) << 16))  # segid + 1; 0 where nothing was drawn
        return {"pixels": np.flipud(self._rgb).copy(),
                "depth": np.flipud(depth).astype(np.float32),
                "segmentation": np.flipud(labels[np.minimum(segid, len(labels) - 1)])}

    def _labels(self, model: mujoco.MjModel, scene: mujoco.MjvScene) -> np.ndarray:
        """The label of each segmentation colour (segid + 1) of this frame's scene."""
        count = scene.ngeom
        labels = np.zeros(count + 2, np.uint8)  # the last: any colour past the scene's geoms
        for i in range(count):
            geom = scene.geoms[i]
            if geom.segid < 0:
                continue
            kind = geom.objtype
            if kind == mujoco.mjtObj.mjOBJ_PLUGIN:  # damaged: fully bruised or torn (docs/model.md#damage)
                labels[geom.segid + 1] = LABELS["damaged" if geom.dataid == DRAWN_DAMAGED else "intestine"]
            elif kind == mujoco.mjtObj.mjOBJ_GEOM:
                labels[geom.segid + 1] = self._geom_label[geom.objid]
            elif kind == mujoco.mjtObj.mjOBJ_SITE:
                labels[geom.segid + 1] = self._site_label[geom.objid]
        return labels


def _assets(model: mujoco.MjModel):
    """What a MuJoCo rendering context holds of a model beyond MuJoCo's built-in shapes, when it
    holds nothing else: then a context made for one such model draws any other (each episode's
    rebuild of the scene is one); None when the model has meshes, textures, height fields, skins,
    flexes or planes (a new context then)."""
    if model.nmesh or model.ntex or model.nhfield or model.nskin or model.nflex or \
            np.any(model.geom_type == mujoco.mjtGeom.mjGEOM_PLANE):  # planes have model-sized display lists
        return None
    return ("built-in shapes only",)


def _model_light(to: mujoco.MjvLight, model: mujoco.MjModel, data: mujoco.MjData, light: int) -> None:
    """Scene light `to` made from the model's light `light` where this state puts it."""
    to.pos[:] = data.light_xpos[light]
    to.dir[:] = data.light_xdir[light]
    for field in ("ambient", "attenuation", "diffuse", "specular"):
        getattr(to, field)[:] = getattr(model, f"light_{field}")[light]
    to.cutoff, to.exponent = float(model.light_cutoff[light]), float(model.light_exponent[light])
    to.bulbradius, to.intensity = float(model.light_bulbradius[light]), float(model.light_intensity[light])
    to.range = float(model.light_range[light])
    to.type, to.texid = int(model.light_type[light]), int(model.light_texid[light])
    to.castshadow, to.headlight, to.id = 0, 0, light


def _tool_names(model: mujoco.MjModel) -> list[str]:
    """Tools of a scene: the bodies named <tool>_trocar."""
    names = [model.body(i).name for i in range(model.nbody)]
    return [name[:-len("_trocar")] for name in names if name.endswith("_trocar")]
