"""Reading intestines out of MuJoCo models and data, and writing their MJCF.

The state of one ``viscera.intestine`` instance in ``data.plugin_state`` is
laid out by the plugin (plugin/mujoco/state_layout.h, with units); Python reads
its blocks by name from ``Intestine.layout`` (positions, velocities,
divergences, recoveries, wrenches, friction, grasps) and never recomputes an
offset.
"""

from __future__ import annotations

import ctypes
import dataclasses
import difflib
import functools
import re
from typing import Any, Mapping

import mujoco
import numpy as np

from viscera import _library

PLUGIN_NAME = "viscera.intestine"


def attribute_names() -> tuple[str, ...]:
    """Config keys the plugin accepts, from the plugin library itself."""
    lib = _library.native()
    return tuple(lib.viscera_attribute_name(i).decode() for i in range(lib.viscera_attribute_count()))


ATTRIBUTE_FIELDS = ("kind", "values", "unit", "default", "meaning")


def _attribute_field(index: int, field: str) -> str:
    library, buffer = _library.native(), ctypes.create_string_buffer(512)
    length = library.viscera_attribute_field(index, field.encode(), buffer, len(buffer))
    if length >= len(buffer):
        buffer = ctypes.create_string_buffer(length + 1)
        library.viscera_attribute_field(index, field.encode(), buffer, len(buffer))
    return buffer.value.decode()


def attribute_docs() -> dict[str, dict[str, str]]:
    """Each config key's kind (real, positive, nonnegative, count, vector, choice, custom), allowed
    values, unit, default and meaning (Markdown), from the plugin's one table of keys
    (plugin/mujoco/keys.h), in the order MuJoCo is told them."""
    return {name: {field: _attribute_field(i, field) for field in ATTRIBUTE_FIELDS}
            for i, name in enumerate(attribute_names())}


def allowed_values(key: str) -> tuple[str, ...]:
    """The names an enumerated config key accepts (integrator, shape, clamped, mass_matrix), as
    the plugin defines them (one list per key, tied to its enum); () for any other key."""
    library = _library.native()
    names = []
    while (name := library.viscera_allowed_value(key.encode(), len(names))) is not None:
        names.append(name.decode())
    return tuple(names)


def spline_points(control_points: np.ndarray, abscissae: np.ndarray) -> np.ndarray:
    """Points of the Catmull-Rom axis at parametric abscissae s in [0, 1] (m, shape (k, 3)).

    Evaluated by the plugin, with its own basis (end closure included), through ctypes: each point
    the four basis terms summed in order, the same bits on every CPU (viscera.numerics).
    """
    q = np.ascontiguousarray(control_points, dtype=np.float64).reshape(-1, 3)
    s = np.ascontiguousarray(abscissae, dtype=np.float64).ravel()
    if q.shape[0] < 4:
        raise ValueError(f"a Catmull-Rom axis needs at least 4 control points, got {q.shape[0]}")
    if s is not _UNIFORM.get(s.size) and not np.isfinite(s).all():  # _uniform's are finite
        raise ValueError("abscissae must be finite")
    points = np.empty((s.size, 3))
    _library.native().viscera_spline_points(q.shape[0], q.ctypes.data, s.size, s.ctypes.data, points.ctypes.data)
    return points


def grid_under_axis(control_points: np.ndarray, samples: int, xs: np.ndarray, ys: np.ndarray,
                    radius: float) -> np.ndarray:
    """Which cells of the grid (xs[i], ys[j]) (m, in the xy plane) the tube of `radius` (m) around
    the Catmull-Rom axis lies over, the axis read at `samples` uniform abscissae: 1.0 where one
    lies within the radius of the cell, else 0.0, in meshgrid's order (rows of y), shape
    (len(ys) * len(xs),). In the plugin (one call): the same booleans as testing the
    axis_points(samples) in numpy (viscera.tasks.base.grid_under_tube)."""
    q = np.ascontiguousarray(control_points, dtype=np.float64).reshape(-1, 3)
    xs = np.ascontiguousarray(xs, dtype=np.float64)
    ys = np.ascontiguousarray(ys, dtype=np.float64)
    if q.shape[0] < 4:
        raise ValueError(f"a Catmull-Rom axis needs at least 4 control points, got {q.shape[0]}")
    s = _uniform(samples)
    out = np.empty(len(xs) * len(ys))
    _library.native().viscera_grid_under_axis(q.shape[0], q.ctypes.data, s.size, s.ctypes.data, len(xs), xs.ctypes.data,
                                              len(ys), ys.ctypes.data, float(radius), float(radius) ** 2,
                                              out.ctypes.data)
    return out


_UNIFORM: dict[int, np.ndarray] = {}  # count -> its abscissae (read-only, shared between calls)


def _uniform(count: int) -> np.ndarray:
    """`count` parametric abscissae from 0 to 1 (read-only: shared between calls)."""
    if count not in _UNIFORM:
        s = np.linspace(0.0, 1.0, count)
        s.flags.writeable = False
        _UNIFORM[count] = s
    return _UNIFORM[count]


def default_stiffnesses(length: float) -> tuple[float, float]:
    """The stretch and bend stiffnesses (N/m) an intestine of rest length `length` (m) takes
    when its config gives neither: one material at any length (keys.h; from the plugin)."""
    out = np.zeros(2)
    if _library.native().viscera_default_stiffnesses(float(length), out.ctypes.data_as(ctypes.c_void_p)):
        raise ValueError(f"length = {length!r}: must be a positive finite number of metres")
    return float(out[0]), float(out[1])


def _info(model: mujoco.MjModel, instance: int) -> np.ndarray | None:
    """Length, radius, mass, control points, spheres, samples per segment, sleep (1 or 0), sleep time
    (s), as the plugin reads them."""
    out = np.zeros(9)
    status = _library.native().viscera_intestine_info(
        ctypes.c_void_p(model._address), instance, out.ctypes.data_as(ctypes.c_void_p))
    return out if status == 0 else None


def _layout(model: mujoco.MjModel, instance: int) -> dict[str, slice]:
    """The blocks of the instance's plugin_state, by name, as the plugin lays them out (from C:
    plugin/mujoco/state_layout.h): positions, velocities, divergences, recoveries, wrenches,
    friction, grasps."""
    library = _library.native()
    count = library.viscera_state_block_count()
    offset, size = np.zeros(count, dtype=np.int32), np.zeros(count, dtype=np.int32)
    total = library.viscera_intestine_layout(ctypes.c_void_p(model._address), instance,
                                             offset.ctypes.data_as(ctypes.c_void_p), size.ctypes.data_as(ctypes.c_void_p))
    if total < 0:
        raise RuntimeError(f"viscera: plugin instance {instance} is not a viscera.intestine")
    return {library.viscera_state_block_name(b).decode(): slice(int(offset[b]), int(offset[b] + size[b]))
            for b in range(count)}


@functools.cache
def _block_widths() -> dict[str, int]:
    """Numbers per item (control point, body, sphere, grasper) of each plugin_state block (from C)."""
    library = _library.native()
    return {library.viscera_state_block_name(b).decode(): library.viscera_state_block_width(b)
            for b in range(library.viscera_state_block_count())}


@functools.cache
def _grasp_status_names() -> dict[int, str]:
    """A grasper's status number to its name: open, holding, closed (from C)."""
    library = _library.native()
    names, i = {}, 0
    while (name := library.viscera_grasp_status_name(i)) is not None:
        names[i] = name.decode()
        i += 1
    return names


@dataclasses.dataclass(frozen=True)
class Grasp:
    """One grasper's hold on the axis."""

    site: str          # the site where the jaws hold
    status: str        # "open", "holding", or "closed" (closed without a hold: missed or slipped)
    abscissa: float    # m along the rest axis from its first point, of the held point (when holding)
    slips: int         # holds lost since the last reset: slid out of the jaws, or torn out past grasp_slip_force

    @property
    def holding(self) -> bool:
        return self.status == "holding"


@dataclasses.dataclass(frozen=True)
class Intestine:
    """One viscera.intestine instance of a compiled model: config and state accessors."""

    model: mujoco.MjModel
    instance: int
    name: str
    config: Mapping[str, str]  # the attributes given in the MJCF, as strings
    rest_length: float         # m, defaults applied
    radius: float              # m, tube and collision sphere radius (at the start, if it tapers)
    mass: float                # kg
    control_count: int
    sphere_count: int
    samples_per_segment: int
    sleeps: bool                 # config key `sleep`, its default applied: points at rest sleep
    sleep_time_s: float          # s, at rest this long a control point sleeps
    layout: Mapping[str, slice]  # plugin_state's blocks (offsets from the instance's plugin_stateadr)
    radius_end: float = 0.0      # m, the radius at the end: `radius` unless the tube tapers (config `radius`, two values)

    def _state(self, data: mujoco.MjData) -> np.ndarray:
        start = int(self.model.plugin_stateadr[self.instance])
        return data.plugin_state[start:start + int(self.model.plugin_statenum[self.instance])]

    def positions(self, data: mujoco.MjData) -> np.ndarray:
        """Control point positions (m, shape (n, 3)), a view into data.plugin_state."""
        return self._state(data)[self.layout["positions"]].reshape(self.control_count, 3)

    def velocities(self, data: mujoco.MjData) -> np.ndarray:
        """Control point velocities (m/s, shape (n, 3)), a view into data.plugin_state."""
        return self._state(data)[self.layout["velocities"]].reshape(self.control_count, 3)

    def asleep(self, data: mujoco.MjData) -> np.ndarray:
        """Which control points sleep (bool, shape (n,)): at rest for `sleep_time` with `sleep`
        on; they are held still until something wakes them (see the config keys)."""
        rest = self._state(data)[self.layout["rest"]].reshape(self.control_count, -1)
        return (rest[:, 0] >= self.sleep_time_s) & self.sleeps

    def body_wrench(self, data: mujoco.MjData, body: int | str) -> np.ndarray:
        """Force (N) and torque (N m, about the body's centre of mass), world frame, that the
        intestine exerted on `body` (id or name), averaged over the last step; shape (6,)."""
        body_id = body if isinstance(body, (int, np.integer)) else self.model.body(body).id
        if not 0 <= body_id < self.model.nbody:
            raise IndexError(f"body {body!r} is not a body of the model (0 to {self.model.nbody - 1})")
        width = _block_widths()["wrenches"]
        return self._state(data)[self.layout["wrenches"]].reshape(-1, width)[int(body_id)].copy()

    @property
    def graspers(self) -> tuple[str, ...]:
        """Names of the sites where grasping jaws hold the axis (config key grasp_sites)."""
        return tuple(self.config.get("grasp_sites", "").split())

    def grasps(self, data: mujoco.MjData) -> list[Grasp]:
        """The hold of every grasper (in grasp_sites order)."""
        state = self._state(data)[self.layout["grasps"]].reshape(-1, _block_widths()["grasps"])
        statuses = _grasp_status_names()
        out = []
        for i, site in enumerate(self.graspers):
            status, s, slips = state[i][0], state[i][1], state[i][-1]  # status, abscissa, ..., slips
            out.append(Grasp(site, statuses.get(int(status), "open"), float(s) * self.rest_length, int(slips)))
        return out

    def damage(self, data: mujoco.MjData) -> np.ndarray:
        """Per control point, its wall's damage (docs/model.md#damage): (n, 2), bruise in [0, 1] and
        torn (0 or 1). A view into the state."""
        return self._state(data)[self.layout["damage"]].reshape(-1, _block_widths()["damage"])

    def pinches(self, data: mujoco.MjData) -> list[tuple[float | None, float]]:
        """Each grasper's (pinch N, slip pull N) now, in grasp_sites order, as the plugin takes them:
        the squeeze of the actuators on its jaw joint where the jaws meet the tissue (None when no
        actuator drives the jaw), and the pull past which a hold slips at that pinch (config
        `grasp_friction`, `grasp_slip_force`; docs/model.md#grasp)."""
        out = np.zeros(2 * max(1, len(self.graspers)))
        count = _library.native().viscera_grasp_pinches(ctypes.c_void_p(self.model._address),
                                                         ctypes.c_void_p(data._address), self.instance,
                                                         out.ctypes.data_as(ctypes.c_void_p), len(out) // 2)
        if count < 0:
            raise RuntimeError(f"viscera: intestine instance {self.instance} is not a viscera.intestine")
        return [(None if out[2 * i] < 0 else float(out[2 * i]), float(out[2 * i + 1])) for i in range(count)]

    def hold_pulls(self, data: mujoco.MjData) -> np.ndarray:
        """Each grasper's hold pulling on the held point now (N, in grasp_sites order; 0 where it holds
        nothing): the hold spring's stretch, from the held point where it sits in the site's frame
        (the grasps block) to the axis point held, times `grasp_stiffness`. What the jaws' friction
        must hold (docs/model.md#grasp); the damping's share is left out."""
        state = self._state(data)[self.layout["grasps"]].reshape(-1, _block_widths()["grasps"])
        stiffness = float(self.config.get("grasp_stiffness", attribute_docs()["grasp_stiffness"]["default"]))
        pulls = np.zeros(len(self.graspers))
        positions = np.ascontiguousarray(self.positions(data))
        statuses = {name: code for code, name in _grasp_status_names().items()}
        for i, site in enumerate(self.graspers):
            if int(state[i][0]) != statuses["holding"]:
                continue
            site_id = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_SITE, site)
            anchor = data.site_xpos[site_id] + data.site_xmat[site_id].reshape(3, 3) @ state[i][2:5]
            held = spline_points(positions, np.array([state[i][1]]))[0]
            pulls[i] = stiffness * float(np.linalg.norm(anchor - held))
        return pulls

    def energy(self, data: mujoco.MjData) -> dict[str, float]:
        """Energies of the axis (J): 'elastic' (every spring, bending and tether term), 'gravity'
        (zero at the origin, under the model's gravity) and 'kinetic' (1/2 v^T M v, consistent mass).
        Rebuilds the plugin's rod to measure (O(n)): for checks, not for every step."""
        q = np.ascontiguousarray(self.positions(data))
        v = np.ascontiguousarray(self.velocities(data))
        gravity = np.ascontiguousarray(self.model.opt.gravity, dtype=np.float64)
        if self.model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_GRAVITY:
            gravity = np.zeros(3)
        out = np.zeros(3)
        status = _library.native().viscera_intestine_energy(
            ctypes.c_void_p(self.model._address), self.instance, q.ctypes.data_as(ctypes.c_void_p),
            v.ctypes.data_as(ctypes.c_void_p), gravity.ctypes.data_as(ctypes.c_void_p),
            out.ctypes.data_as(ctypes.c_void_p))
        if status != 0:
            raise RuntimeError(f"viscera: cannot evaluate the energy of intestine instance {self.instance}")
        return {"elastic": float(out[0]), "gravity": float(out[1]), "kinetic": float(out[2])}

    def stability(self) -> dict[str, float]:
        """How finely the plugin integrates this intestine at the model's timestep: the highest
        angular frequencies of its elastic forces and of its contact springs at the initial shape
        ('elastic_rad_s', 'contact_rad_s', rad/s) and the substeps it takes per MuJoCo step
        ('substeps': the config's, else the fewest the estimate allows; docs/integrators.md).
        Rebuilds the plugin's rod to measure (O(n)): for a scene's setup, not for every step."""
        out = np.zeros(3)
        if _library.native().viscera_intestine_stability(ctypes.c_void_p(self.model._address), self.instance,
                                                         out.ctypes.data_as(ctypes.c_void_p)):
            raise RuntimeError(f"viscera: cannot estimate the stability of intestine instance {self.instance}")
        return {"elastic_rad_s": float(out[0]), "contact_rad_s": float(out[1]), "substeps": int(out[2])}

    def divergence_count(self, data: mujoco.MjData) -> int:
        """Steps since the last reset that diverged even at the most retried substeps: their
        positions were restored to the step start and their velocities zeroed."""
        return int(self._state(data)[self.layout["divergences"]][0])

    def recovery_count(self, data: mujoco.MjData) -> int:
        """Steps since the last reset that diverged at the configured substeps and held when
        retried with more (up to 2**divergence_retries times as many)."""
        return int(self._state(data)[self.layout["recoveries"]][0])

    def axis_points(self, data: mujoco.MjData, count: int = 1000) -> np.ndarray:
        """`count` points of the axis, uniform in parametric abscissa (m, shape (count, 3))."""
        return spline_points(self.positions(data), _uniform(count))

    def sphere_centres(self, data: mujoco.MjData) -> np.ndarray:
        """Collision sphere centres (m, shape (spheres, 3))."""
        return spline_points(self.positions(data), np.linspace(0.0, 1.0, self.sphere_count))

    def length(self, data: mujoco.MjData, count: int = 4000) -> float:
        """Current length of the axis (m), from `count` points along it."""
        points = self.axis_points(data, count)
        return float(np.linalg.norm(np.diff(points, axis=0), axis=1).sum())


def intestines(model: mujoco.MjModel) -> list[Intestine]:
    """Every viscera.intestine instance of a compiled model."""
    names = attribute_names()
    found = []
    raw = bytes(model.plugin_attr)
    for instance in range(model.nplugin):
        info = _info(model, instance)
        if info is None:
            continue  # another plugin's instance
        # MuJoCo stores each instance's values NUL-terminated, in attribute order
        start = int(model.plugin_attradr[instance])
        values = raw[start:].split(b"\0")[:len(names)]
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_PLUGIN, instance) or f"intestine{instance}"
        config = {key: value.decode() for key, value in zip(names, values) if value}
        found.append(Intestine(model, instance, name, config, rest_length=float(info[0]), radius=float(info[1]),
                               mass=float(info[2]), control_count=int(info[3]), sphere_count=int(info[4]),
                               samples_per_segment=int(info[5]), sleeps=bool(info[6]), sleep_time_s=float(info[7]),
                               radius_end=float(info[8]),
                               layout=_layout(model, instance)))
    return found


FIXED_WIDTH = "{: .16e}"  # every double in 23 characters, exactly: values rewritten in place keep their width


def damage_colours() -> tuple[np.ndarray, np.ndarray]:
    """The rgb (in [0, 1]) the plugin's renderer draws a fully bruised wall and a torn one in
    (docs/model.md#damage); the healthy colour blends towards the first as the bruise deepens."""
    out = np.zeros(6)
    _library.native().viscera_damage_colours(out.ctypes.data_as(ctypes.c_void_p))
    return out[:3], out[3:]


def fixed_width_numbers(values: Any) -> str:
    """`values` (numbers, any shape) as config text of a width set by their count alone (23
    characters a number, round-tripping every double): a model compiled with such text can have
    them rewritten in place (reconfigure)."""
    return " ".join(map(FIXED_WIDTH.format, np.ravel(np.asarray(values, dtype=float)).tolist()))


def reconfigure(model: mujoco.MjModel, data: mujoco.MjData, instance: int, config: Mapping[str, str]) -> None:
    """Rewrite config keys of intestine `instance` in the compiled `model` in place, then rebuild
    `data`'s plugin caches from them: another episode's tissue or start without compiling (about
    a millisecond against a compile's 10). Each new value must have exactly the length of the
    compiled one (fixed_width_numbers writes such text). `data`'s state is left as it is: call
    mj_resetData next to start from the new config's initial shape. Other MjData of `model`
    read the new config when they next build their caches (a copy, a reset of a new data).
    A bad key, a value of another width or an invalid config raises ValueError naming it, and
    leaves the model and the data as they were."""
    names = attribute_names()
    start = int(model.plugin_attradr[instance])
    end = int(model.plugin_attradr[instance + 1]) if instance + 1 < model.nplugin else len(model.plugin_attr)
    raw = model.plugin_attr[start:end]
    values = bytes(raw).split(b"\0")
    offsets = np.cumsum([0] + [len(v) + 1 for v in values])
    before = raw.copy()
    for key, text in config.items():
        if key not in names:
            raise ValueError(unknown_key_message(key))
        index = names.index(key)
        new = str(text).encode()
        if len(new) != len(values[index]):
            raise ValueError(f"config key {key!r}: the new value has {len(new)} characters, the compiled model holds "
                             f"{len(values[index])}; compile it with text of the width you will write "
                             "(viscera.intestine.fixed_width_numbers)")
        raw[offsets[index]:offsets[index] + len(new)] = np.frombuffer(new, dtype=np.int8)
    error = ctypes.create_string_buffer(512)
    if _library.native().viscera_intestine_reconfigure(ctypes.c_void_p(model._address), ctypes.c_void_p(data._address),
                                                        instance, error, len(error)):
        raw[:] = before
        raise ValueError(load_error_message(error.value.decode()))


def intestine(model: mujoco.MjModel, name: str | None = None) -> Intestine:
    """The intestine called `name` (or the only one) of a compiled model."""
    found = intestines(model)
    if name is not None:
        found = [it for it in found if it.name == name or it.name.endswith("/" + name)]
    if len(found) != 1:
        raise KeyError(f"expected one viscera.intestine named {name!r}, found {[it.name for it in found]}")
    return found[0]


def _format(value: Any) -> str:
    if isinstance(value, str):
        return value
    if isinstance(value, (bool, np.bool_)):
        return "1" if value else "0"
    if isinstance(value, (int, float, np.integer, np.floating)):
        return repr(float(value)) if isinstance(value, (float, np.floating)) else str(int(value))
    array = np.asarray(value).ravel()
    if array.dtype.kind in "iu":
        return " ".join(str(int(x)) for x in array)
    return " ".join(repr(float(x)) for x in array)


def unknown_key_message(key: str) -> str:
    """The message for a config key the plugin does not know, with the nearest known key."""
    close = difflib.get_close_matches(key, attribute_names(), n=1, cutoff=0.6)
    hint = f" (did you mean '{close[0]}'?)" if close else f" (known keys: {', '.join(sorted(attribute_names()))})"
    return f"unknown config key '{key}' for plugin {PLUGIN_NAME}{hint}"


# MuJoCo's compiler refuses an undeclared plugin attribute before the plugin sees
# it, in its own words (with a stray quote): "unrecognized attribute
# 'plugin:lenght' for plugin viscera.intestine'"
_MUJOCO_UNKNOWN_KEY = re.compile(r"unrecognized attribute 'plugin:([^']*)' for plugin " + re.escape(PLUGIN_NAME) + "'?")


# the plugin refuses a config in its init with a warning: MuJoCo then raises its own line above ours
_MUJOCO_INIT_FAILED = re.compile(r"^(?:Error: )?engine error: plugin->init failed for plugin id \d+\n")


def load_error_message(message: object) -> str:
    """A model-loading error message with MuJoCo's wording for a misspelled intestine config
    key replaced by unknown_key_message (naming the key, suggesting the nearest), and a config
    the plugin refused as the plugin's own message (once; MuJoCo's "plugin->init failed" line
    above it dropped); any other message comes back unchanged."""
    text = _MUJOCO_UNKNOWN_KEY.sub(lambda match: unknown_key_message(match.group(1)), str(message))
    if _MUJOCO_INIT_FAILED.match(text):
        lines = _MUJOCO_INIT_FAILED.sub("", text).splitlines()
        text = "\n".join(dict.fromkeys(line for line in lines if line.strip()))  # each line once, in order
    return text


def config_strings(**config: Any) -> dict[str, str]:
    """Config values as the strings MJCF carries; unknown keys raise ValueError."""
    unknown = sorted(set(config) - set(attribute_names()))
    if unknown:
        raise ValueError("; ".join(unknown_key_message(key) for key in unknown))
    return {key: _format(value) for key, value in config.items()}


def extension_xml(name: str = "intestine", **config: Any) -> str:
    """The ``<extension>`` element declaring one intestine, as an MJCF string."""
    lines = [f'<extension>\n  <plugin plugin="{PLUGIN_NAME}">\n    <instance name="{name}">']
    for key, value in config_strings(**config).items():
        lines.append(f'      <config key="{key}" value="{value}"/>')
    lines.append("    </instance>\n  </plugin>\n</extension>")
    return "\n".join(lines)


def add_to_mjcf(root: Any, name: str = "intestine", **config: Any) -> Any:
    """Add an intestine instance to a dm_control.mjcf root element; returns the instance element."""
    plugins = [p for p in root.extension.get_children("plugin") if p.plugin == PLUGIN_NAME]
    plugin = plugins[0] if plugins else root.extension.add("plugin", plugin=PLUGIN_NAME)
    instance = plugin.add("instance", name=name)
    for key, value in config_strings(**config).items():
        instance.add("config", key=key, value=value)
    return instance


_SKIN_SIZES: dict[tuple, tuple[int, int]] = {}  # per (model address, instance, resolution): the last sizes


def skin(model: mujoco.MjModel, data: mujoco.MjData, instance: int | str = 0,
         rings_per_segment: int | None = None, ring_points: int | None = None):
    """The intestine's skin (paper 3.2): a closed generalised cylinder around its axis.

    Returns (vertices (V, 3) in m, unit normals (V, 3), triangles (T, 3) vertex
    indices), triangles counter-clockwise seen from outside. `instance` is the
    plugin instance index or the intestine's name. Resolution from the config
    keys skin_rings_per_segment and skin_ring_points (or the arguments, e.g. a
    coarser skin for recordings), radii from radius_min and radius_max.
    """
    if (rings_per_segment is not None and rings_per_segment < 1) or (ring_points is not None and ring_points < 3):
        raise ValueError(f"a skin needs rings_per_segment >= 1 and ring_points >= 3, got {rings_per_segment} "
                         f"and {ring_points}")
    index = intestine(model, instance).instance if isinstance(instance, str) else int(instance)
    if not 0 <= index < model.nplugin:
        raise KeyError(f"plugin instance {instance!r} is not a viscera.intestine")
    rings, points = rings_per_segment or 0, ring_points or 0  # 0: the config's resolution
    start = int(model.plugin_stateadr[index])
    state = np.ascontiguousarray(data.plugin_state[start:start + int(model.plugin_statenum[index])], dtype=np.float64)
    key = (model._address, index, rings, points)
    nv, nt = _SKIN_SIZES.get(key, (0, 0))  # a guess: the plugin says if it does not fit
    counts = (ctypes.c_int(0), ctypes.c_int(0))
    for _ in range(2):
        vertices, normals = np.empty((nv, 3)), np.empty((nv, 3))
        triangles = np.empty((nt, 3), dtype=np.int32)
        status = _library.native().viscera_skin(
            ctypes.c_void_p(model._address), ctypes.c_void_p(data._address), index, rings, points, state.ctypes.data_as(ctypes.c_void_p), nv, nt,
            vertices.ctypes.data_as(ctypes.c_void_p), normals.ctypes.data_as(ctypes.c_void_p),
            triangles.ctypes.data_as(ctypes.c_void_p), ctypes.byref(counts[0]), ctypes.byref(counts[1]))
        if status != 1:
            break
        nv, nt = counts[0].value, counts[1].value
        if len(_SKIN_SIZES) > 256:  # many models come and go: keep it small
            _SKIN_SIZES.clear()
        _SKIN_SIZES[key] = (nv, nt)
    if status < 0 and _info(model, index) is None:
        raise KeyError(f"plugin instance {instance!r} is not a viscera.intestine")
    if status != 0:
        raise ValueError("the intestine's state cannot be skinned (non-finite control points?)")
    if (nv, nt) != (counts[0].value, counts[1].value):  # built into larger arrays than it needed
        vertices, normals, triangles = vertices[:counts[0].value], normals[:counts[0].value], triangles[:counts[1].value]
    return vertices, normals, triangles
