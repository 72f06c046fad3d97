"""The laparoscope a trainee steers: a scope pivoting about its port, with 0 or 30 degree optics.

    scope = Laparoscope.of(physics, optics_deg=30)   # after a task's reset: its pose as the episode aimed it
    pose = scope.initial.copy()                      # (pitch deg, yaw deg, depth m, roll deg)
    pose[0] += 5.0
    scope.apply(physics, pose)                       # the camera and its light moved (model values)

The scope is a straight shaft through a port in the anterior wall, as a surgeon's assistant holds
it: it pivots about the port (pitch about x, then yaw about y, the tools' convention: shaft
direction u = (-sin yaw, cos yaw sin pitch, -cos yaw cos pitch)), slides along its shaft (depth:
the tip's distance from the port, m) and turns about it (roll). Its optics look along the shaft
(0 degrees) or 30 degrees off it, towards the image's top (a forward-oblique scope held with
its light post down, so that the shaft stands steeper than the view): turning a 30 degree
scope sweeps its view around the shaft. The image's up is
the cranial direction (+y) made square to the shaft, turned by the roll.

The episode's aim (viscera.tasks: the camera turned to look at the working area, from where the
scene puts it) is the starting pose: the view along the aimed direction, the roll 0, and the
port where the shaft through the camera crosses the port's height (the scene's
`laparoscope_port` site's). So the first frame is the episode's, whatever the optics. The pose
is written into the model (the camera's and its light's position and orientation, model values
as the aim is), never into the state: steering the camera changes no physics. The arithmetic is
Python's `math` on floats, the same bits on every CPU (viscera.numerics).
"""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np

COORDINATES = ("pitch", "yaw", "depth", "roll")   # deg, deg, m, deg
OPTICS_DEG = (0.0, 30.0)                          # the scopes a trainer offers
LOWER = np.array([-75.0, -75.0, 0.005, -180.0])   # deg, deg, m, deg: the shaft within 75 degrees of vertical
UPPER = np.array([75.0, 75.0, 0.15, 180.0])       # the tip at most 15 cm in; a full turn either way
SPEED = np.array([30.0, 30.0, 0.05, 60.0])        # deg/s, m/s: what an assistant's steady hand does
CENTRE_FRACTION = 0.5  # a point is centred within this fraction of the image's half extents


def _sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def _add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def _scale(a, s: float):
    return (a[0] * s, a[1] * s, a[2] * s)


def _dot(a, b) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _unit(a):
    length = math.sqrt(_dot(a, a))
    return _scale(a, 1.0 / length)


def _vector(values):
    return tuple(float(x) for x in values)


def shaft_direction(pitch_deg: float, yaw_deg: float):
    pitch, yaw = math.radians(pitch_deg), math.radians(yaw_deg)
    return (-math.sin(yaw), math.cos(yaw) * math.sin(pitch), -math.cos(yaw) * math.cos(pitch))


def level_up(shaft):
    """The cranial direction (+y) made square to `shaft`, unit; +z's where the shaft is along y."""
    for axis in ((0.0, 1.0, 0.0), (0.0, 0.0, 1.0)):
        up = _sub(axis, _scale(shaft, _dot(axis, shaft)))
        if _dot(up, up) > 1e-12:
            return _unit(up)
    raise ValueError("no up direction")


def image_point(model, data, camera: int, point) -> tuple[float, float] | None:
    """Where `point` (m) is in camera `camera`'s image, in fractions of the image's half height
    (x right, y up; a square image's edges at +-1); None behind the camera."""
    frame = data.cam_xmat[camera]
    relative = _sub(_vector(point), _vector(data.cam_xpos[camera]))
    local = [_dot((float(frame[0 + c]), float(frame[3 + c]), float(frame[6 + c])), relative) for c in range(3)]
    if local[2] >= 0.0:
        return None
    half = math.tan(math.radians(float(model.cam_fovy[camera])) / 2.0)
    return local[0] / (-local[2] * half), local[1] / (-local[2] * half)


def horizon_of(frame) -> float:
    """How far a camera's image up is turned from the cranial direction (+y) seen in its image
    (deg, 0 to 180; `frame`: its cam_xmat, 9 numbers): 0 with the horizon level."""
    x, y, z = ((float(frame[c]), float(frame[3 + c]), float(frame[6 + c])) for c in range(3))
    up = level_up(z)  # +y square to the view axis: the cranial direction in the image plane
    return abs(math.degrees(math.atan2(_dot(up, x), _dot(up, y))))


@dataclasses.dataclass
class Laparoscope:
    """The scope of one episode: its port and optics, and the pose it started from."""

    port: tuple           # m, world
    optics_deg: float
    initial: np.ndarray   # (4,) pitch deg, yaw deg, depth m, roll deg
    lower: np.ndarray     # (4,) the pose's range: LOWER and UPPER, grown to hold the initial pose
    upper: np.ndarray
    camera: int           # the laparoscope camera's id
    body: int             # its body's id
    lights: tuple         # ids of the lights on that body (the scope's own)

    @classmethod
    def of(cls, physics, optics_deg: float = 0.0) -> "Laparoscope | None":
        """The scope as the episode aimed it (see the module doc); None if the scene has no
        laparoscope camera and port."""
        if float(optics_deg) not in OPTICS_DEG:
            raise ValueError(f"optics = {optics_deg!r}: must be one of {', '.join(f'{o:g}' for o in OPTICS_DEG)} degrees")
        model, data = physics.model.ptr, physics.data.ptr
        camera = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, "laparoscope")
        site = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, "laparoscope_port")
        if camera < 0 or site < 0:
            return None
        mujoco.mj_camlight(model, data)
        eye = _vector(data.cam_xpos[camera])
        frame = data.cam_xmat[camera]
        view = (-float(frame[2]), -float(frame[5]), -float(frame[8]))   # the camera looks along its -z
        up = (float(frame[1]), float(frame[4]), float(frame[7]))
        angle = math.radians(float(optics_deg))
        shaft = _unit(_sub(_scale(view, math.cos(angle)), _scale(up, math.sin(angle))))
        shaft_up = _unit(_add(_scale(up, math.cos(angle)), _scale(view, math.sin(angle))))
        height = float(data.site_xpos[site][2])
        depth = (height - eye[2]) / -shaft[2]           # back along the shaft to the port's height
        port = _sub(eye, _scale(shaft, depth))
        pitch = math.degrees(math.atan2(shaft[1], -shaft[2]))
        yaw = math.degrees(math.asin(min(1.0, max(-1.0, -shaft[0]))))
        level = level_up(shaft)
        right = _cross(level, _scale(shaft, -1.0))
        roll = math.degrees(math.atan2(-_dot(shaft_up, right), _dot(shaft_up, level)))
        lights = tuple(i for i in range(model.nlight) if model.light_bodyid[i] == model.cam_bodyid[camera])
        initial = np.array([pitch, yaw, depth, roll])
        return cls(port, float(optics_deg), initial, np.minimum(LOWER, initial), np.maximum(UPPER, initial), camera,
                   int(model.cam_bodyid[camera]), lights)

    def frame(self, pose) -> tuple:
        """The camera's position (m) and its x (right), y (up) and z (back) axes, world frame, at
        `pose` (pitch deg, yaw deg, depth m, roll deg)."""
        pitch, yaw, depth, roll = (float(x) for x in pose)
        shaft = shaft_direction(pitch, yaw)
        level = level_up(shaft)
        right = _cross(level, _scale(shaft, -1.0))
        r = math.radians(roll)
        shaft_up = _add(_scale(level, math.cos(r)), _scale(right, -math.sin(r)))
        angle = math.radians(self.optics_deg)
        view = _add(_scale(shaft, math.cos(angle)), _scale(shaft_up, math.sin(angle)))
        y = _sub(_scale(shaft_up, math.cos(angle)), _scale(shaft, math.sin(angle)))
        z = _scale(view, -1.0)
        x = _cross(y, z)
        return _add(self.port, _scale(shaft, depth)), x, y, z

    def apply(self, physics, pose) -> None:
        """Put the camera and its light at `pose` (model values), then update their world poses."""
        model, data = physics.model.ptr, physics.data.ptr
        position, x, y, z = self.frame(pose)
        body_rotation = data.xmat[self.body]
        origin = data.xpos[self.body]
        offset = _sub(position, _vector(origin))
        # world to the body's frame: R^T v, with R's rows read from xmat (row-major)
        columns = [(float(body_rotation[0 + c]), float(body_rotation[3 + c]), float(body_rotation[6 + c]))
                   for c in range(3)]
        local = [_dot(column, offset) for column in columns]
        axes = [tuple(_dot(column, axis) for column in columns) for axis in (x, y, z)]  # each axis in the body frame
        matrix = np.array([[axes[0][0], axes[1][0], axes[2][0]], [axes[0][1], axes[1][1], axes[2][1]],
                           [axes[0][2], axes[1][2], axes[2][2]]])
        model.cam_pos[self.camera] = local
        mujoco.mju_mat2Quat(model.cam_quat[self.camera], matrix.ravel())
        for light in self.lights:
            model.light_pos[light] = local
            model.light_dir[light] = [-axes[2][0], -axes[2][1], -axes[2][2]]
        mujoco.mj_camlight(model, data)

    def image_point(self, physics, point) -> tuple[float, float] | None:
        """image_point of this scope's camera now."""
        return image_point(physics.model.ptr, physics.data.ptr, self.camera, point)

    def horizon_deg(self, physics) -> float:
        """horizon_of this scope's camera now."""
        return horizon_of(physics.data.ptr.cam_xmat[self.camera])

    def follow(self, physics, pose: np.ndarray, point, dt: float) -> np.ndarray:
        """The next pose of an assistant keeping `point` (m) centred: pitch and yaw turned to bring
        it to the image's centre, no faster than SPEED, by a Newton step on the image point's
        finite-difference Jacobian in pitch and yaw (any optics and roll); depth and roll kept."""
        def seen(candidate) -> tuple[float, float] | None:
            self.apply(physics, candidate)
            return self.image_point(physics, point)

        now = seen(pose)
        if now is None:
            return pose.copy()
        step = 0.5  # deg
        columns = []
        for k in (0, 1):
            moved = pose.copy()
            moved[k] += step
            after = seen(moved)
            if after is None:
                self.apply(physics, pose)
                return pose.copy()
            columns.append(((after[0] - now[0]) / step, (after[1] - now[1]) / step))
        self.apply(physics, pose)
        (a, c), (b, d) = columns  # image (x, y) per degree of pitch, of yaw
        determinant = a * d - b * c
        if abs(determinant) < 1e-12:
            return pose.copy()
        change = ((d * -now[0] - b * -now[1]) / determinant, (-c * -now[0] + a * -now[1]) / determinant)
        reach = SPEED[:2] * dt
        nxt = pose.copy()
        nxt[0] += min(max(change[0], -reach[0]), reach[0])
        nxt[1] += min(max(change[1], -reach[1]), reach[1])
        return np.clip(nxt, self.lower, self.upper)

    def centred(self, physics, point) -> bool:
        where = self.image_point(physics, point)
        return where is not None and max(abs(where[0]), abs(where[1])) <= CENTRE_FRACTION
