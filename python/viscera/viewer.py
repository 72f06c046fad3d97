"""meshcat viewer: live, recorded (self-contained HTML), usable from Python.

    viewer = MeshcatViewer(model)          # serves on 127.0.0.1 only (serve=False: no server, record only)
    print(viewer.url)                      # open in a browser
    viewer.update(data)                    # after mj_step: geom poses and the intestine's skin
    viewer.record(data)                    # keep a frame for the recording
    viewer.save("run.html")                # offline page that plays the recording
    viewer.close()

Every visible geom of the model (groups 0-2, alpha > 0) is drawn with its
colour: plane, box, sphere, capsule, cylinder, ellipsoid, mesh, height field.
Each intestine is drawn as its skin (viscera.skin). meshcat animations move
whole objects only, so a recording uploads one skin mesh per recorded frame
and toggles visibility; `record_rings_per_segment` / `record_ring_points`
(coarser than the live skin) bound the file size.
"""

from __future__ import annotations

import base64
import json
import os
import selectors
import signal
import subprocess
import sys
import threading
import time
import weakref

import meshcat
import meshcat.animation
import meshcat.geometry as g
import mujoco
import numpy as np
import umsgpack
import zmq

import viscera
from viscera.checks import camera_id
from viscera.meshcat_server import VIEWER_ROOT, Scene

INTESTINE_RGB = (0.85, 0.45, 0.45)
MARKED_RGB = (0.25, 0.5, 0.9)  # the config key marked_band's stretch, as MuJoCo's renderer draws it


def intestine_rgba(gut: viscera.Intestine) -> tuple[float, ...]:
    """The colour `gut` is drawn in: its config's `rgba`, else INTESTINE_RGB, opaque (as MuJoCo's
    renderer draws it)."""
    given = gut.config.get("rgba")
    return tuple(float(x) for x in given.split()) if given else (*INTESTINE_RGB, 1.0)


def skin_colours(gut: viscera.Intestine, vertex_count: int, damage: np.ndarray | None = None,
                 rings_per_segment: int | None = None) -> np.ndarray | None:
    """Per-vertex colours (V, 3) of `gut`'s skin at `rings_per_segment` (by default its config's):
    MARKED_RGB on the rings within its `marked_band`, its own colour (intestine_rgba) elsewhere,
    then the wall's `damage` (Intestine.damage: bruise, torn per control point) drawn as MuJoCo's
    renderer draws it (viscera.damage_colours): darker towards a bruise's purple as it deepens,
    dark red where torn. None with neither a band nor damage. Rings are uniform in the spline
    parameter ((n - 1) rings_per_segment + 1 of them), the two cap centres last."""
    band = gut.config.get("marked_band")
    damaged = damage is not None and bool(np.any(damage))
    if not band and not damaged:
        return None
    if rings_per_segment is None:
        rings_per_segment = int(gut.config.get("skin_rings_per_segment",
                                                viscera.attribute_docs()["skin_rings_per_segment"]["default"]))
    rings = (gut.control_count - 1) * rings_per_segment + 1
    ring_points = (vertex_count - 2) // rings
    fraction = np.arange(rings) / (rings - 1)
    ring_rgb = np.tile(np.array(intestine_rgba(gut)[:3]), (rings, 1))
    if band:
        start, end = (float(x) / gut.rest_length for x in band.split())
        ring_rgb[(fraction >= start) & (fraction <= end)] = MARKED_RGB
    if damaged:
        bruise_rgb, torn_rgb = viscera.damage_colours()
        x = fraction * (gut.control_count - 1)
        j = np.minimum(np.floor(x).astype(int), gut.control_count - 2)
        w = x - j
        bruise = np.clip((1.0 - w) * damage[j, 0] + w * damage[j + 1, 0], 0.0, 1.0)[:, None]
        torn = damage[np.where(w < 0.5, j, j + 1), 1] > 0.0
        ring_rgb = (1.0 - bruise) * ring_rgb + bruise * bruise_rgb
        ring_rgb[torn] = torn_rgb
    colours = np.tile(np.array(intestine_rgba(gut)[:3]), (vertex_count, 1))
    colours[:rings * ring_points] = np.repeat(ring_rgb, ring_points, axis=0)
    return colours


def _colour(rgb) -> int:
    r, gg, b = (int(round(255 * float(np.clip(c, 0, 1)))) for c in rgb[:3])
    return (r << 16) | (gg << 8) | b


def _material(rgba) -> g.MeshLambertMaterial:
    alpha = float(rgba[3])
    if alpha < 1.0:  # a see-through wall must not hide, in the depth buffer, what lies behind it
        return g.MeshLambertMaterial(color=_colour(rgba), opacity=alpha, transparent=True, depthWrite=False)
    return g.MeshLambertMaterial(color=_colour(rgba), opacity=alpha, transparent=False)


def _revolved(profile_r: np.ndarray, profile_z: np.ndarray, segments: int = 24) -> g.TriangularMeshGeometry:
    """A closed surface of revolution about z from (r, z) profile points (first and last on the axis)."""
    angles = np.linspace(0.0, 2 * np.pi, segments, endpoint=False)
    vertices = [[r * np.cos(a), r * np.sin(a), z] for r, z in zip(profile_r, profile_z) for a in angles]
    faces = []
    for i in range(len(profile_r) - 1):
        for j in range(segments):
            a, b = i * segments + j, i * segments + (j + 1) % segments
            faces += [[a, b, a + segments], [b, b + segments, a + segments]]
    return g.TriangularMeshGeometry(np.array(vertices), np.array(faces))


def _capsule(radius: float, half: float) -> g.TriangularMeshGeometry:
    bottom, top = np.linspace(-np.pi / 2, 0.0, 5), np.linspace(0.0, np.pi / 2, 5)  # the two hemispheres
    r = np.concatenate([radius * np.cos(bottom), radius * np.cos(top)])
    z = np.concatenate([-half + radius * np.sin(bottom), half + radius * np.sin(top)])
    return _revolved(r, z)


def _cylinder(radius: float, half: float) -> g.TriangularMeshGeometry:
    return _revolved(np.array([0.0, radius, radius, 0.0]), np.array([-half, -half, half, half]))


def _heightfield(model: mujoco.MjModel, hfield: int) -> g.TriangularMeshGeometry:
    rows, cols = model.hfield_nrow[hfield], model.hfield_ncol[hfield]
    sx, sy, top, _ = model.hfield_size[hfield]
    z = model.hfield_data[model.hfield_adr[hfield]:model.hfield_adr[hfield] + rows * cols].reshape(rows, cols) * top
    x, y = np.meshgrid(np.linspace(-sx, sx, cols), np.linspace(-sy, sy, rows))
    vertices = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)
    faces = []
    for i in range(rows - 1):
        for j in range(cols - 1):
            a = i * cols + j
            faces += [[a, a + 1, a + cols], [a + 1, a + cols + 1, a + cols]]
    return g.TriangularMeshGeometry(vertices, np.array(faces))


def geom_geometry(model: mujoco.MjModel, geom: int):
    """meshcat geometry of a MuJoCo geom in its own frame, or None if not drawable."""
    return _shape(model, model.geom_type[geom], model.geom_size[geom], model.geom_dataid[geom])


def site_geometry(model: mujoco.MjModel, site: int):
    """meshcat geometry of a MuJoCo site (sphere, capsule, ellipsoid, cylinder or box) in its own frame."""
    return _shape(model, model.site_type[site], model.site_size[site], -1)


def _shape(model: mujoco.MjModel, kind: int, size: np.ndarray, dataid: int):
    T = mujoco.mjtGeom
    if kind == T.mjGEOM_PLANE:
        sx, sy = (size[0] or 5.0), (size[1] or 5.0)  # size 0: an infinite plane
        return g.Box([2 * sx, 2 * sy, 0.002])
    if kind == T.mjGEOM_BOX:
        return g.Box(2 * size)
    if kind == T.mjGEOM_SPHERE:
        return g.Sphere(size[0])
    if kind == T.mjGEOM_ELLIPSOID:
        return g.Ellipsoid(size)
    if kind == T.mjGEOM_CAPSULE:
        return _capsule(size[0], size[1])
    if kind == T.mjGEOM_CYLINDER:
        return _cylinder(size[0], size[1])
    if kind == T.mjGEOM_MESH:
        mesh = dataid
        v0, nv = model.mesh_vertadr[mesh], model.mesh_vertnum[mesh]
        f0, nf = model.mesh_faceadr[mesh], model.mesh_facenum[mesh]
        return g.TriangularMeshGeometry(model.mesh_vert[v0:v0 + nv], model.mesh_face[f0:f0 + nf])
    if kind == T.mjGEOM_HFIELD:
        return _heightfield(model, dataid)
    return None


def part_transform(data: mujoco.MjData, part: tuple[str, int]) -> np.ndarray:
    """World pose of a drawn part, ("geoms", id) or ("sites", id), as a 4 x 4 matrix."""
    kind, index = part
    prefix = kind[:-1]  # geom_xpos, site_xpos
    transform = np.eye(4)
    transform[:3, :3] = getattr(data, f"{prefix}_xmat")[index].reshape(3, 3)
    transform[:3, 3] = getattr(data, f"{prefix}_xpos")[index]
    return transform


def _html(commands: dict[tuple[bytes, bytes, bytes], bytes]) -> str:
    """A self-contained page that draws `commands` (a Scene's) with meshcat's bundled viewer.

    Unlike meshcat's own page (one fetch() per command, resolved in any order and
    after the page says it has loaded), the scene is drawn in order, at once; an
    animation starts after the first frames are drawn, so that the time spent loading
    its meshes does not eat into its start.
    """
    with open(os.path.join(VIEWER_ROOT, "main.min.js")) as f:
        script = f.read()
    later = "requestAnimationFrame(() => requestAnimationFrame(() => draw({})));\n"
    draw = "".join((later if kind == b"set_animation" else "draw({});\n").format(f'"{base64.b64encode(data).decode()}"')
                   for (kind, _, _), data in commands.items())
    return ("<!DOCTYPE html>\n<html><head><meta charset=utf-8><title>MeshCat</title>"
            "<style>body {margin: 0;} #meshcat-pane {width: 100vw; height: 100vh; overflow: hidden;}</style>"
            f"</head><body><div id=\"meshcat-pane\"></div><script>{script}</script><script>\n"
            "var viewer = new MeshCat.Viewer(document.getElementById(\"meshcat-pane\"));\n"
            "function draw(b64) {\n"
            "  const text = atob(b64), bytes = new Uint8Array(text.length);\n"
            "  for (let i = 0; i < text.length; i++) bytes[i] = text.charCodeAt(i);\n"
            "  viewer.handle_command_bytearray(bytes);\n"
            f"}}\n{draw}</script></body></html>")


class _Local:
    """meshcat's window (what `meshcat.Visualizer` sends through) that only keeps the scene:
    the latest command per (kind, path, property), in order, from which a page is written."""

    web_url = None

    def __init__(self, scene: Scene | None = None):
        self.scene = scene if scene is not None else Scene(keep_deletes=False)

    def send(self, command) -> None:
        lowered = command.lower()
        key = (lowered["type"].encode(), lowered["path"].encode(), lowered.get("property", "").encode())
        self.keep(key, umsgpack.packb(lowered))

    def keep(self, key: tuple[bytes, bytes, bytes], data: bytes) -> None:
        self.scene.add(*key, data)

    def sync(self, timeout: float) -> dict | None:
        return None

    def get_scene(self) -> str:
        return _html(self.scene.commands)

    def close(self) -> None:
        pass


class _Channel(_Local):
    """A `_Local` window that also sends every command to the server over a one-way socket.

    `send` never waits for the server: a command the socket cannot take now stays in
    a backlog where a newer command for the same thing replaces it, and goes with the
    next send. The whole scene is also kept here, so a page is written without the server.
    """

    def __init__(self, zmq_url: str, web_url: str):
        super().__init__()
        self.web_url = web_url
        self.backlog = Scene(keep_deletes=True)
        self.context = zmq.Context()
        self.socket = self.context.socket(zmq.DEALER)
        self.socket.setsockopt(zmq.SNDHWM, 64)  # a few frames in flight; beyond that, latest wins in the backlog
        self.socket.setsockopt(zmq.LINGER, 0)
        self.socket.connect(zmq_url)
        self._token = 0

    def keep(self, key: tuple[bytes, bytes, bytes], data: bytes) -> None:
        self.scene.add(*key, data)
        self.backlog.add(*key, data)
        self.push()

    def push(self) -> bool:
        """Hand the backlog to the socket as far as it takes it now; True if all went."""
        for key, data in list(self.backlog.commands.items()):
            try:
                self.socket.send_multipart([*key, data], flags=zmq.NOBLOCK)
            except zmq.Again:
                return False
            del self.backlog.commands[key]
        return True

    def sync(self, timeout: float) -> dict | None:
        """Wait up to `timeout` s until the server has every command sent so far; its status, or None."""
        deadline = time.monotonic() + timeout
        while not self.push():
            left = deadline - time.monotonic()
            if left <= 0 or not self.socket.poll(1000 * left, zmq.POLLOUT):
                return None
        self._token += 1
        token = str(self._token).encode()
        try:
            self.socket.send_multipart([b"sync", token], flags=zmq.NOBLOCK)
        except zmq.Again:
            return None
        while (left := deadline - time.monotonic()) > 0 and self.socket.poll(1000 * left, zmq.POLLIN):
            _, answered, status = self.socket.recv_multipart()
            if answered == token:  # older answers belong to syncs that timed out
                return json.loads(status)
        return None

    def close(self) -> None:
        self.socket.close(linger=0)
        self.context.term()


def _stop_server(server: subprocess.Popen, channel: _Channel | None) -> None:
    """Stop the server and release the pipes and sockets (run by weakref.finalize: also at exit)."""
    if channel is not None:
        channel.close()
    if server.stdin and not server.stdin.closed:
        server.stdin.close()  # end of file: the server's own watchdog stops it
    if server.poll() is None:
        server.terminate()
        try:
            server.wait(timeout=10)
        except subprocess.TimeoutExpired:
            server.kill()
            server.wait()
    for pipe in (server.stdout, server.stderr):
        if pipe and not pipe.closed:
            pipe.close()


def _interrupt(signum, frame):
    raise KeyboardInterrupt  # SIGTERM ends hold() as Ctrl-C does


def _visible(model: mujoco.MjModel, geom: int) -> bool:
    return model.geom_group[geom] < 3 and model.geom_rgba[geom][3] > 0


def _site_visible(model: mujoco.MjModel, site: int) -> bool:
    """Drawn as MuJoCo's renderer draws it by default: groups 0-2, not fully transparent."""
    return model.site_group[site] < 3 and model.site_rgba[site][3] > 0


def scene_bounds(model: mujoco.MjModel, data: mujoco.MjData) -> tuple[np.ndarray, float]:
    """Centre and radius of the visible geoms (planes aside: they are unbounded) and the intestines."""
    points = []
    for geom in range(model.ngeom):
        if not _visible(model, geom) or model.geom_type[geom] == mujoco.mjtGeom.mjGEOM_PLANE:
            continue
        offset, half = model.geom_aabb[geom, :3], model.geom_aabb[geom, 3:]
        corners = offset + half * np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])
        points.append(data.geom_xpos[geom] + corners @ data.geom_xmat[geom].reshape(3, 3).T)
    for gut in viscera.intestines(model):
        points.append(gut.positions(data))
    if not points:
        return np.zeros(3), 1.0
    points = np.concatenate(points)
    low, high = points.min(axis=0), points.max(axis=0)
    return (low + high) / 2, max(float(np.linalg.norm(high - low)) / 2, 1e-3)


def camera_view(model: mujoco.MjModel, camera: int | str | None = None) -> tuple[np.ndarray, np.ndarray, float]:
    """Eye, target and vertical field of view (degrees) that frame the model in its initial state.

    `camera` is a MuJoCo camera name or id; None: the model's first camera, or if it has
    none, a view from MuJoCo's default azimuth and elevation that fits the bounds of the
    visible geoms and the intestines. The target is on the camera's axis at the depth of
    the scene's centre: meshcat orbits about it.
    """
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    mujoco.mj_camlight(model, data)
    centre, radius = scene_bounds(model, data)
    if camera is None and model.ncam > 0:
        camera = 0
    if camera is None:
        fovy = float(model.vis.global_.fovy)
        azimuth, elevation = np.radians([model.vis.global_.azimuth, model.vis.global_.elevation])
        forward = np.array([np.cos(elevation) * np.cos(azimuth), np.cos(elevation) * np.sin(azimuth),
                            np.sin(elevation)])
        distance = 1.1 * radius / np.sin(np.radians(fovy) / 2)
        return centre - distance * forward, centre, fovy
    index = camera_id(model, camera)
    eye = data.cam_xpos[index].copy()
    forward = -data.cam_xmat[index].reshape(3, 3)[:, 2]
    depth = max(float(np.dot(centre - eye, forward)), 0.1 * radius)
    return eye, eye + depth * forward, float(model.cam_fovy[index])


class MeshcatViewer:
    """A meshcat view of a MuJoCo model with intestines, served on `host` only
    (`serve=False`: no server, for recordings alone; `url` is then None).

    The page opens framed on the scene: from `camera` (a MuJoCo camera name or id;
    default: the model's first camera, or a view that fits the scene), with that
    camera's field of view; meshcat's grid and axes are hidden (planes are drawn as
    geoms), MuJoCo's transparency is kept. A recorded page (`save`) opens the same.

    Browsers may come and go at any time. Nothing waits for them: `update` hands the
    state to the server process (`python -m viscera.meshcat_server`) and returns; a slow
    browser is sent the latest state when it is ready for more, skipping frames.

    The server ends with the viewer: `close()`, the end of a `with` block, garbage
    collection, interpreter exit, or the end of this process by any signal, SIGKILL too.

    `hold()` keeps the page up after a run, showing the last state, until Ctrl-C or
    SIGTERM.
    """

    def __init__(self, model: mujoco.MjModel, host: str = "127.0.0.1", camera: int | str | None = None,
                 record_rings_per_segment: int = 1, record_ring_points: int = 8, timeout: float = 30.0,
                 serve: bool = True):
        self.model = model
        self.vis = None
        self.url = None
        self._server = None
        eye, target, fovy = camera_view(model, camera)  # a bad camera fails before a server starts
        if not serve:  # a recorder: the scene is kept here only, for `save`; no process, no port
            self._channel = _Local()
            self._finalizer = weakref.finalize(self, lambda: None)
            self.vis = meshcat.Visualizer(window=self._channel)
            self._build(record_rings_per_segment, record_ring_points)
            self._frame(eye, target, fovy)
            return
        # a session of its own: Ctrl-C in the terminal goes to this process, which decides
        self._server = subprocess.Popen(
            [sys.executable, "-m", "viscera.meshcat_server", "--host", host, "--parent", str(os.getpid())],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True)
        self._channel = None
        self._finalizer = weakref.finalize(self, _stop_server, self._server, None)
        try:
            zmq_url, self.url = self._read_urls(timeout)
            for pipe in (self._server.stdout, self._server.stderr):
                pipe.close()  # the server prints nothing more
            self._channel = _Channel(zmq_url, self.url)
            self._finalizer.detach()
            self._finalizer = weakref.finalize(self, _stop_server, self._server, self._channel)
            self.vis = meshcat.Visualizer(window=self._channel)
            self._build(record_rings_per_segment, record_ring_points)
            self._frame(eye, target, fovy)
        except BaseException:
            self.close()
            raise

    def _read_urls(self, timeout: float) -> tuple[str, str]:
        """The zmq and web URLs the server prints when it is up, within `timeout` s."""
        urls: dict[str, str] = {}
        deadline = time.monotonic() + timeout
        pending = b""
        stdout = self._server.stdout.fileno()  # raw reads: select and buffered readline do not mix
        with selectors.DefaultSelector() as selector:
            selector.register(stdout, selectors.EVENT_READ)
            while len(urls) < 2:
                left = deadline - time.monotonic()
                if left <= 0 or not selector.select(left):
                    raise RuntimeError(f"the meshcat server did not start within {timeout} s")
                chunk = os.read(stdout, 4096)
                if not chunk:
                    self._server.wait(timeout=5)
                    error = self._server.stderr.read().decode(errors="replace")
                    raise RuntimeError(f"the meshcat server stopped: {error.strip()[-500:]}")
                pending += chunk
                *lines, pending = pending.split(b"\n")
                for line in lines:
                    key, _, value = line.decode(errors="replace").strip().partition("=")
                    if key in ("zmq_url", "web_url"):
                        urls[key] = value
        return urls["zmq_url"], urls["web_url"]

    def _build(self, record_rings_per_segment: int, record_ring_points: int) -> None:
        model = self.model
        self.intestines = viscera.intestines(model)
        self._rgba = {gut.name: intestine_rgba(gut) for gut in self.intestines}
        self.record_resolution = (record_rings_per_segment, record_ring_points)
        self.frames: list[tuple[dict, dict]] = []
        self.geoms = []
        for geom in range(model.ngeom):
            shape = geom_geometry(model, geom) if _visible(model, geom) else None
            if shape is None:
                continue
            # MuJoCo's rule: a material's colour applies unless the geom sets its own rgba
            material, rgba = model.geom_matid[geom], model.geom_rgba[geom]
            if material >= 0 and np.allclose(rgba, [0.5, 0.5, 0.5, 1.0]):
                rgba = model.mat_rgba[material]
            self.vis["geoms"][str(geom)].set_object(shape, _material(rgba))
            self.geoms.append(geom)
        # sites too (the cavity's target area, trocars, jaw tips), as MuJoCo's renderer shows them
        self.sites = [site for site in range(model.nsite) if _site_visible(model, site)]
        for site in self.sites:
            self.vis["sites"][str(site)].set_object(site_geometry(model, site), _material(model.site_rgba[site]))
        self.parts = [("geoms", geom) for geom in self.geoms] + [("sites", site) for site in self.sites]
        bodies = np.array([(model.geom_bodyid if kind == "geoms" else model.site_bodyid)[index]
                           for kind, index in self.parts], dtype=int)
        moving = (model.body_weldid[bodies] != 0) | (model.body_mocapid[model.body_rootid[bodies]] >= 0)
        self._moving = [part for part, moves in zip(self.parts, moving) if moves]
        self._placed = False
        self._skin_materials = {gut.name: _material(intestine_rgba(gut)) for gut in self.intestines}
        for helper in ("/Axes", "/Grid"):  # drawn through the scene; planes are drawn as geoms
            self.vis[helper].set_property("visible", False)

    def _frame(self, eye: np.ndarray, target: np.ndarray, fovy: float) -> None:
        """Point meshcat's camera from `eye` at `target`, vertical field of view `fovy` degrees.

        meshcat's orbit controls always look at the origin of three.js's world, so the
        scene (everything under /meshcat) is shifted to put `target` there; the camera's
        position is in three.js's y-up frame: (x, y, z) -> (x, z, -y).
        """
        offset = np.asarray(eye, float) - target
        distance = float(np.linalg.norm(offset))
        if abs(offset[2]) > 0.999 * distance:
            # looking along the orbit's up axis leaves the picture's up undefined:
            # tilt a hair towards -y so that +y is up, as in MuJoCo's top views
            offset[1] -= 1e-3 * distance
        shift = np.eye(4)
        shift[:3, 3] = -np.asarray(target, float)
        self.vis.set_transform(shift)
        camera = self.vis["/Cameras/default/rotated/<object>"]
        camera.set_property("position", [float(offset[0]), float(offset[2]), float(-offset[1])])
        camera.set_property("fov", float(fovy))
        camera.set_property("near", distance / 100)
        camera.set_property("far", distance * 100)

    def update(self, data: mujoco.MjData) -> None:
        """Show the state of `data`: geom poses and every intestine's skin. Never waits for a browser."""
        for kind, index in self._moving if self._placed else self.parts:  # the others never move
            self.vis[kind][str(index)].set_transform(part_transform(data, (kind, index)))
        self._placed = True
        for gut in self.intestines:
            vertices, _, triangles = viscera.skin(self.model, data, gut.instance)
            colours = skin_colours(gut, len(vertices), gut.damage(data))
            if colours is None:
                self.vis["intestines"][gut.name].set_object(g.TriangularMeshGeometry(vertices, triangles),
                                                           self._skin_materials[gut.name])
            else:  # a marked band or damage: vertex colours
                self.vis["intestines"][gut.name].set_object(
                    g.TriangularMeshGeometry(vertices, triangles, color=colours),
                    g.MeshLambertMaterial(color=0xFFFFFF, vertexColors=True))

    def set_intestines_visible(self, visible: bool) -> None:
        self.vis["intestines"].set_property("visible", bool(visible))

    def record(self, data: mujoco.MjData) -> None:
        """Keep the state of `data` as the next frame of the recording (a coarser skin)."""
        rings, points = self.record_resolution
        skins = {}
        for gut in self.intestines:
            vertices, _, triangles = viscera.skin(self.model, data, gut.instance, rings, points)
            skins[gut.name] = (vertices, triangles, skin_colours(gut, len(vertices), gut.damage(data).copy(), rings))
        # the first frame places the parts that never move too (the page may never have had an update)
        poses = {part: part_transform(data, part) for part in (self._moving if self.frames else self.parts)}
        self.frames.append((skins, poses))

    def save(self, path: str, fps: float = 10.0) -> int:
        """Write the recording, played at `fps` frames per second, as a self-contained HTML page
        that plays it offline; returns its size in bytes.

        The page is built from a copy of the scene: the live view (and every browser on it) is
        left as it is, so `hold` after `save` still shows the final state.
        """
        vis = meshcat.Visualizer(window=_Local(self._channel.scene.copy(keep_deletes=False)))
        animation = meshcat.animation.Animation(default_framerate=fps)
        count, moving = len(self.frames), set(self._moving)
        if count:  # the recording replaces the live skin; before it starts, the page shows its first frame
            vis["intestines"].delete()
            for (kind, index), transform in self.frames[0][1].items():
                vis[kind][str(index)].set_transform(transform)
        # meshcat 0.3.2's viewer ignores boolean (visibility) tracks but plays transform
        # tracks: a frame's mesh waits 1 km below the scene and is in place on its frame
        # only, with keyframes a thousandth of a frame apart so that nothing slides
        home, away = np.eye(4), np.eye(4)
        away[2, 3] = -1000.0
        for k, (skins, poses) in enumerate(self.frames):
            # each object's clip loops on its own length: every track spans frames 0 to
            # `count`, so the clips loop together; recorded frame k shows on [k, k + 1),
            # the first one also before the animation starts
            shown = {0: k == 0, k: True, k + 0.999: True, count: k == count - 1}
            if k > 0:
                shown[k - 0.001] = False
            if k + 1 < count:
                shown[k + 1] = False
            keys = [(time_in_frames, home if on else away) for time_in_frames, on in sorted(shown.items())]
            for name, (vertices, triangles, colours) in skins.items():
                node = vis["recording"][name][str(k)]
                # a material object per frame: meshcat's page loads objects sharing one badly
                if colours is None:
                    node.set_object(g.TriangularMeshGeometry(vertices, triangles), _material(self._rgba[name]))
                else:
                    node.set_object(g.TriangularMeshGeometry(vertices, triangles, color=colours),
                                    g.MeshLambertMaterial(color=0xFFFFFF, vertexColors=True))
                node.set_transform(home if k == 0 else away)
                for time_in_frames, transform in keys:
                    with animation.at_frame(vis, time_in_frames) as frame:
                        frame["recording"][name][str(k)].set_transform(transform)
            with animation.at_frame(vis, k) as frame:
                for (kind, index), transform in poses.items():
                    if (kind, index) in moving:
                        frame[kind][str(index)].set_transform(transform)
        if count > 1:
            vis.set_animation(animation, play=True, repetitions=1000)
        html = vis.static_html()
        with open(path, "w") as f:
            f.write(html)
        return len(html.encode())

    def flush(self, timeout: float = 5.0) -> dict | None:
        """Wait up to `timeout` s until the server has everything sent so far.

        Returns the server's status (`browsers` connected now, `connections` since it
        started, `commands` received, malformed messages `dropped`), or None if it did not answer in time. Never
        raises; updates do not need it: it is for scripts and tests that must know.
        """
        return self._channel.sync(timeout) if self._channel is not None else None

    @property
    def serving(self) -> bool:
        """Whether the server is up (False without one: `serve=False`, closed, or died)."""
        return self._server is not None and self.vis is not None and self._server.poll() is None

    def _check_serving(self) -> None:
        if self._server is None or self.vis is None:
            raise RuntimeError("this viewer has no meshcat server (made with serve=False, or closed)")
        if self._server.poll() is not None:
            raise RuntimeError(f"the meshcat server stopped (exit status {self._server.returncode}): "
                               "nothing is served any more")

    def hold(self, timeout: float | None = None) -> None:
        """Keep serving the last state until Ctrl-C or SIGTERM (or `timeout` s), then return.

        For a look at the final state after a run; `close()` after it (or use `with`).
        RuntimeError if there is no server to hold: none, or it has stopped (before or
        during the hold).
        """
        self._check_serving()
        self.flush()
        previous = None
        if threading.current_thread() is threading.main_thread():
            previous = signal.signal(signal.SIGTERM, _interrupt)
        try:
            self._server.wait(timeout)
        except (KeyboardInterrupt, subprocess.TimeoutExpired):
            return
        finally:
            if previous is not None:
                signal.signal(signal.SIGTERM, previous)
        self._check_serving()  # the wait ended: the server died under us

    def close(self) -> None:
        """Stop the server and release its pipes and sockets (idempotent)."""
        self.vis = None
        self._finalizer()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
