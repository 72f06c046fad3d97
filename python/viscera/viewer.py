"""meshcat viewer: live, recorded (self-contained HTML), usable from Python.

    viewer = MeshcatViewer(model)          # serves on 127.0.0.1 only
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

import os
import selectors
import subprocess
import sys
import time

import meshcat
import meshcat.animation
import meshcat.geometry as g
import mujoco
import numpy as np
import zmq

import viscera

INTESTINE_RGB = (0.85, 0.45, 0.45)


def _colour(rgb) -> int:
    r, gg, b = (int(round(255 * float(np.clip(c, 0, 1)))) for c in rgb[:3])
    return (r << 16) | (gg << 8) | b


def _material(rgba) -> g.MeshLambertMaterial:
    alpha = float(rgba[3])
    return g.MeshLambertMaterial(color=_colour(rgba), opacity=alpha, transparent=alpha < 1.0)


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
    kind, size = model.geom_type[geom], model.geom_size[geom]
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
        mesh = model.geom_dataid[geom]
        v0, nv = model.mesh_vertadr[mesh], model.mesh_vertnum[mesh]
        f0, nf = model.mesh_faceadr[mesh], model.mesh_facenum[mesh]
        return g.TriangularMeshGeometry(model.mesh_vert[v0:v0 + nv], model.mesh_face[f0:f0 + nf])
    if kind == T.mjGEOM_HFIELD:
        return _heightfield(model, model.geom_dataid[geom])
    return None


def geom_transform(data: mujoco.MjData, geom: int) -> np.ndarray:
    transform = np.eye(4)
    transform[:3, :3] = data.geom_xmat[geom].reshape(3, 3)
    transform[:3, 3] = data.geom_xpos[geom]
    return transform


class MeshcatViewer:
    """A meshcat view of a MuJoCo model with intestines, served on `host` only."""

    def __init__(self, model: mujoco.MjModel, host: str = "127.0.0.1", record_rings_per_segment: int = 1,
                 record_ring_points: int = 8, timeout: float = 30.0):
        self.model = model
        self.vis = None
        self._server = subprocess.Popen([sys.executable, "-m", "viscera.meshcat_server", "--host", host],
                                        stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        try:
            zmq_url, self.url = self._read_urls(timeout)
            self.vis = meshcat.Visualizer(zmq_url=zmq_url)
            # a dead server must raise, not hang: meshcat's request socket waits forever by default
            self.vis.window.zmq_socket.setsockopt(zmq.RCVTIMEO, int(timeout * 1000))
            self.vis.window.zmq_socket.setsockopt(zmq.LINGER, 0)
            self._build(record_rings_per_segment, record_ring_points)
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
        self.record_resolution = (record_rings_per_segment, record_ring_points)
        self.frames: list[tuple[dict, dict]] = []
        self.geoms = []
        for geom in range(model.ngeom):
            visible = model.geom_group[geom] < 3 and model.geom_rgba[geom][3] > 0
            shape = geom_geometry(model, geom) if visible else None
            if shape is None:
                continue
            # MuJoCo's rule: a material's colour applies unless the geom sets its own rgba
            material, rgba = model.geom_matid[geom], model.geom_rgba[geom]
            if material >= 0 and np.allclose(rgba, [0.5, 0.5, 0.5, 1.0]):
                rgba = model.mat_rgba[material]
            self.vis["geoms"][str(geom)].set_object(shape, _material(rgba))
            self.geoms.append(geom)
        self._moving = [geom for geom in self.geoms if model.body_weldid[model.geom_bodyid[geom]] != 0]
        self._skin_material = _material((*INTESTINE_RGB, 1.0))
        self.vis["/Cameras/default/rotated/<object>"].set_property("position", [1.0, 0.8, 1.0])

    def update(self, data: mujoco.MjData) -> None:
        """Show the state of `data`: geom poses and every intestine's skin."""
        for geom in self.geoms:
            self.vis["geoms"][str(geom)].set_transform(geom_transform(data, geom))
        for gut in self.intestines:
            vertices, _, triangles = viscera.skin(self.model, data, gut.instance)
            self.vis["intestines"][gut.name].set_object(g.TriangularMeshGeometry(vertices, triangles),
                                                       self._skin_material)

    def set_intestines_visible(self, visible: bool) -> None:
        self.vis["intestines"].set_property("visible", bool(visible))

    def record(self, data: mujoco.MjData) -> None:
        """Keep the state of `data` as the next frame of the recording (a coarser skin)."""
        rings, points = self.record_resolution
        skins = {gut.name: viscera.skin(self.model, data, gut.instance, rings, points)[::2] for gut in self.intestines}
        poses = {geom: geom_transform(data, geom) for geom in self._moving}
        self.frames.append((skins, poses))

    def save(self, path: str, fps: float = 10.0) -> int:
        """Write the recording as a self-contained HTML page that plays it offline; returns its size in bytes."""
        animation = meshcat.animation.Animation(default_framerate=fps)
        count = len(self.frames)
        # meshcat 0.3.2's viewer ignores boolean (visibility) tracks but plays transform
        # tracks: a frame's mesh waits 1 km below the scene and is in place on its frame
        # only, with keyframes a thousandth of a frame apart so that nothing slides
        home, away = np.eye(4), np.eye(4)
        away[2, 3] = -1000.0
        for k, (skins, poses) in enumerate(self.frames):
            # each object's clip loops on its own length: every track starts parked at
            # frame 0 and ends at the same last frame, so the clips loop together;
            # recorded frame k shows on animation frame k + 1
            keys = [(0, away), (k + 0.999, away), (k + 1, home), (k + 1.999, home), (k + 2, away), (count + 1, away)]
            for name, (vertices, triangles) in skins.items():
                node = self.vis["recording"][name][str(k)]
                # a material object per frame: meshcat's page loads objects sharing one badly
                node.set_object(g.TriangularMeshGeometry(vertices, triangles), _material((*INTESTINE_RGB, 1.0)))
                node.set_transform(away)
                for time_in_frames, transform in keys:
                    with animation.at_frame(self.vis, time_in_frames) as frame:
                        frame["recording"][name][str(k)].set_transform(transform)
            with animation.at_frame(self.vis, k + 1) as frame:
                for geom, transform in poses.items():
                    frame["geoms"][str(geom)].set_transform(transform)
        self.vis["intestines"].delete()  # the recording replaces the live skin
        self.vis.set_animation(animation, play=True, repetitions=1000)
        html = self.vis.static_html()
        with open(path, "w") as f:
            f.write(html)
        return len(html.encode())

    def close(self) -> None:
        """Stop the server and release its pipes and sockets (idempotent)."""
        if self.vis is not None:
            self.vis.window.zmq_socket.close(linger=0)
            self.vis = None
        if self._server.poll() is None:
            self._server.terminate()
            try:
                self._server.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self._server.kill()
                self._server.wait()
        for pipe in (self._server.stdout, self._server.stderr):
            if pipe and not pipe.closed:
                pipe.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
