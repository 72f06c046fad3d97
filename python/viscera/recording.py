"""Recordings: an episode of a task as its seed and the command of every control tick, replayed
bit for bit.

    recording = record("clear_area", seed=3, policy="scripted")   # or a person's: viscera.teleop
    recording = record("clear_area", seed=3, policy="bc.npz")     # or a policy file's (viscera.policy_file)
    recording.save("episode.npz")
    recording = load("episode.npz")
    result = replay(recording)          # result.final_state_sha256 == recording.final_state_sha256

A recording is one `.npz` file (NumPy's zip; written to a temporary name, then renamed, so an
interrupted write never leaves a half file under the name) with two arrays:
- `meta`: UTF-8 JSON: `format` ("viscera-recording"), `version` (1), `task`, `scene` (the
  cavity, viscera.tasks.scene.SCENES; a file without it is the box abdomen's), `seed`, `policy`
  ("scripted", "random", "idle", "person:<device>" or, for a policy file,
  "file:<file name>#<first 12 hex digits of the file's SHA-256>"), `policy_seed` (random only),
  `control_timestep_s`, `time_limit_s`, `steps`, `success`, `final_state_sha256`, the
  `viscera` and `mujoco` versions, `created` (UTC);
- `actions`: float64 (steps, actuators), the dm_env action of every control tick (rad, m);
- `camera` (format version 2, where the laparoscope was steered: meta `camera` is then
  {"optics_deg": 0 or 30}, else null): float64 (steps, 4), the laparoscope's pose during every
  control tick, set before the tick's step (viscera.laparoscope: pitch deg, yaw deg, depth m,
  roll deg). The camera moves no physics; the replay sets it so that the score (what the camera
  saw) and the video are the session's.

Version 1 files (no camera) are read as before.

The task's seed fixes its episode (the bowel, tissue, tilt and target), so the actions are the
whole episode: `replay` loads the task with the seed, control period and time limit, steps
every action, and must end in the same state. `final_state_sha256` is the SHA-256 of the final
`mjSTATE_FULLPHYSICS` state (float64 bytes), the intestine's plugin state included.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import json
import math
import os
import pathlib
import zipfile
from collections.abc import Callable

import mujoco
import numpy as np

from viscera import atomic, provenance

FORMAT = "viscera-recording"
VERSION = 2
POLICIES = ("scripted", "random", "idle")
# what every recording's meta holds (created and the versions are informative only)
REQUIRED = ("task", "seed", "policy", "control_timestep_s", "time_limit_s", "steps", "success", "final_state_sha256")


MAX_SEED = 2 ** 32 - 1             # numpy's RandomState, which the tasks draw their episodes from, takes no more
MAX_TIME_LIMIT_S = 1e6             # simulated s: the command line's longest episode (cli.MAX_DURATION_S)
MAX_CONTROL_TIMESTEP_S = 1.0       # s: the tools are driven at 50 Hz; a control period of seconds is no episode
MAX_META_BYTES = 1 << 20           # a recording's meta is under 1 kB
MAX_ACTIONS_BYTES = 1 << 32        # 4 GiB: a MAX_TIME_LIMIT_S episode at 50 Hz, 9 actuators (3.6 GB)
ENTRIES = {"meta": (np.dtype(np.uint8), 1, MAX_META_BYTES), "actions": (np.dtype("<f8"), 2, MAX_ACTIONS_BYTES),
           "camera": (np.dtype("<f8"), 2, MAX_ACTIONS_BYTES)}
CAMERA_BOUNDS = (np.array([-180.0, -180.0, 0.0, -180.0]), np.array([180.0, 180.0, 1.0, 180.0]))  # deg, deg, m, deg


class RecordingError(ValueError):
    """A recording that cannot be read: the message is one line naming what is wrong."""


@dataclasses.dataclass
class Recording:
    task: str
    seed: int | None
    policy: str
    control_timestep_s: float
    time_limit_s: float
    actions: np.ndarray                  # (steps, actuators) float64, rad and m
    success: bool = False
    final_state_sha256: str = ""
    policy_seed: int | None = None
    created: str = ""
    versions: dict = dataclasses.field(default_factory=dict)
    scene: str = "abdomen"               # the cavity (viscera.tasks.scene.SCENES)
    camera: np.ndarray | None = None     # (steps, 4) the steered laparoscope's pose per tick (viscera.laparoscope)
    optics_deg: float = 0.0              # its optics, where steered

    @property
    def steps(self) -> int:
        return int(len(self.actions))

    def meta(self) -> dict:
        return {"format": FORMAT, "version": VERSION, "task": self.task, "scene": self.scene, "seed": self.seed,
                "policy": self.policy,
                "policy_seed": self.policy_seed, "control_timestep_s": self.control_timestep_s,
                "time_limit_s": self.time_limit_s, "steps": self.steps, "success": bool(self.success),
                "final_state_sha256": self.final_state_sha256, "created": self.created,
                "camera": None if self.camera is None else {"optics_deg": self.optics_deg}, **self.versions}

    def save(self, path: str | os.PathLike) -> None:
        """Write the recording to `path` (.npz); never a half file under that name."""
        path = pathlib.Path(path)
        meta = np.frombuffer(json.dumps(self.meta()).encode(), dtype=np.uint8)
        arrays = {"meta": meta, "actions": np.asarray(self.actions, dtype=np.float64)}
        if self.camera is not None:
            arrays["camera"] = np.asarray(self.camera, dtype=np.float64)
        atomic.save_npz(path, compressed=True, **arrays)


versions, _now = provenance.versions, provenance.now  # what a recording keeps of its making


def load(path: str | os.PathLike) -> Recording:
    """The recording in `path`; RecordingError (one line) for anything wrong with the file, whatever
    its bytes: every entry is read and every value checked (type, shape, finiteness, range) before
    anything is built or stepped from it."""
    import viscera.tasks
    name = str(path)
    if not os.path.exists(path):
        raise RecordingError(f"{name}: no such file")
    if os.path.isdir(path):
        raise RecordingError(f"{name}: a folder, not a recording")
    if not zipfile.is_zipfile(path):
        with open(path, "rb") as file:
            start = file.read(4)
        if start == b"PK\x03\x04":  # a zip's first entry, its directory at the end gone: cut short
            raise RecordingError(f"{name}: truncated (the .npz file ends before its zip directory)")
        raise RecordingError(f"{name}: not a viscera recording (not an .npz file)")
    arrays = _read_entries(path, name)
    try:
        meta = json.loads(arrays["meta"].tobytes().decode())
    except (ValueError, UnicodeDecodeError, RecursionError):  # RecursionError: JSON nested thousands deep
        raise RecordingError(f"{name}: corrupt: its 'meta' entry is not JSON") from None
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        raise RecordingError(f"{name}: not a viscera recording "
                             f"(format {_short(meta.get('format')) if isinstance(meta, dict) else None})")
    version = meta.get("version")
    if not _is_int(version) or version < 1:
        raise RecordingError(f"{name}: bad format version {_short(version)}")
    if version > VERSION:
        raise RecordingError(f"{name}: format version {_short(version)} is newer than this viscera reads "
                             f"({VERSION}): upgrade viscera")
    for key in REQUIRED:
        if key not in meta:
            raise RecordingError(f"{name}: its meta has no {key!r}")
    if "actions" not in arrays:
        raise RecordingError(f"{name}: no 'actions' entry")
    task = meta["task"]
    if not isinstance(task, str) or task not in viscera.tasks.ALL:
        raise RecordingError(f"{name}: unknown task {_short(task)}; known: {', '.join(viscera.tasks.ALL)}")
    scene = meta.get("scene", "abdomen")
    if not isinstance(scene, str) or scene not in viscera.tasks.scene.SCENES:
        raise RecordingError(f"{name}: unknown scene {_short(scene)}; known: {', '.join(viscera.tasks.scene.SCENES)}")
    for key in ("seed", "policy_seed"):
        value = meta.get(key)
        if value is not None and (not _is_int(value) or not 0 <= value <= MAX_SEED):
            raise RecordingError(f"{name}: {key} {_short(value)} is not an integer from 0 to 2^32 - 1")
    for key, limit in (("control_timestep_s", MAX_CONTROL_TIMESTEP_S), ("time_limit_s", MAX_TIME_LIMIT_S)):
        value = meta[key]
        if not _is_number(value) or not value > 0:  # NaN too
            raise RecordingError(f"{name}: {key} {_short(value)} is not a positive number")
        if not value <= limit:  # compared before any float(): an integer of 400 digits overflows it
            raise RecordingError(f"{name}: {key} {_short(value)} is more than {limit:g} s")
    if not isinstance(meta["policy"], str) or not meta["policy"] or not meta["policy"].isprintable():  # one line
        raise RecordingError(f"{name}: policy {_short(meta['policy'])} is not a name")
    if not isinstance(meta["success"], bool):
        raise RecordingError(f"{name}: success {_short(meta['success'])} is not true or false")
    digest = meta["final_state_sha256"]
    if not isinstance(digest, str) or len(digest) != 64 or not set(digest) <= set("0123456789abcdef"):
        raise RecordingError(f"{name}: final_state_sha256 {_short(digest)} is not a SHA-256 (64 hex digits)")
    actions = arrays["actions"]
    if actions.dtype != np.float64 or actions.ndim != 2:
        raise RecordingError(f"{name}: actions must be a 2-D float64 array, got {actions.dtype} {actions.shape}")
    if not np.all(np.isfinite(actions)):
        raise RecordingError(f"{name}: actions hold NaN or infinite values")
    expected = meta["steps"]
    if not _is_int(expected) or expected != len(actions):
        raise RecordingError(f"{name}: meta says {_short(expected)} steps, the actions hold {len(actions)}")
    width, physics_timestep_s, low, high = _task_shape(task, scene)
    if actions.shape[1] != width:
        raise RecordingError(f"{name}: actions of {actions.shape[1]} values per tick, the task {task!r} takes {width}")
    # a policy's commands stay within the action spec (the task moves toward them at the tools' speeds, MuJoCo
    # clamps them); a span's margin each side keeps any overshoot, while 1e308 (deg from rad: inf) is corrupt
    outside = (actions < low - (high - low)) | (actions > high + (high - low))
    if np.any(outside):
        tick, actuator = (int(i) for i in np.argwhere(outside)[0])
        raise RecordingError(f"{name}: action {actions[tick, actuator]!r} at tick {tick}, actuator {actuator}, is far "
                             f"outside the task's range [{low[actuator]:g}, {high[actuator]:g}]")
    control_timestep_s, time_limit_s = float(meta["control_timestep_s"]), float(meta["time_limit_s"])
    if control_timestep_s < physics_timestep_s or not _whole_physics_steps(control_timestep_s, physics_timestep_s):
        raise RecordingError(f"{name}: control_timestep_s {control_timestep_s!r} is not a whole number of the "
                             f"task's physics steps ({physics_timestep_s:g} s)")
    # dm_control ends the episode at about this step (+ 1: its count is of physics steps, within rounding);
    # the quotient is finite, the period at least a physics step and the limit at most MAX_TIME_LIMIT_S
    if len(actions) > math.ceil(time_limit_s / control_timestep_s) + 1:
        raise RecordingError(f"{name}: {len(actions)} steps, more than its time limit ({time_limit_s!r} s) at its "
                             f"control period ({control_timestep_s!r} s) allows")
    camera, optics_deg = _camera(name, meta, arrays, len(actions))
    versions = {k: _short(meta[k], quoted=False) for k in ("viscera", "mujoco") if k in meta}
    created = meta.get("created", "")
    return Recording(task, meta["seed"], meta["policy"], control_timestep_s, time_limit_s, actions, meta["success"],
                     digest, meta.get("policy_seed"), created if isinstance(created, str) else "", versions, scene,
                     camera, optics_deg)


def _camera(name: str, meta: dict, arrays: dict, steps: int) -> tuple[np.ndarray | None, float]:
    """The camera track and its optics (see the module doc), checked; (None, 0.0) without one."""
    from viscera.laparoscope import OPTICS_DEG
    described = meta.get("camera")
    if described is None:
        if "camera" in arrays:
            raise RecordingError(f"{name}: a 'camera' entry, but its meta describes no camera")
        return None, 0.0
    if not isinstance(described, dict) or set(described) != {"optics_deg"}:
        raise RecordingError(f"{name}: camera {_short(described)} is not {{\"optics_deg\": 0 or 30}}")
    optics = described["optics_deg"]
    if not _is_number(optics) or optics not in OPTICS_DEG:
        raise RecordingError(f"{name}: camera optics_deg {_short(optics)} is not one of "
                             f"{', '.join(f'{o:g}' for o in OPTICS_DEG)}")
    if "camera" not in arrays:
        raise RecordingError(f"{name}: its meta describes a camera, but it has no 'camera' entry")
    camera = arrays["camera"]
    if camera.dtype != np.float64 or camera.shape != (steps, 4):
        raise RecordingError(f"{name}: camera must be float64 of shape ({steps}, 4), got {camera.dtype} {camera.shape}")
    if not np.all(np.isfinite(camera)):
        raise RecordingError(f"{name}: camera holds NaN or infinite values")
    low, high = CAMERA_BOUNDS
    outside = (camera < low) | (camera > high)
    if np.any(outside):
        tick, coordinate = (int(i) for i in np.argwhere(outside)[0])
        raise RecordingError(f"{name}: camera {('pitch', 'yaw', 'depth', 'roll')[coordinate]} "
                             f"{camera[tick, coordinate]!r} at tick {tick} is outside [{low[coordinate]:g}, "
                             f"{high[coordinate]:g}]")
    return camera, float(optics)


def _read_entries(path: str | os.PathLike, name: str) -> dict[str, np.ndarray]:
    """The arrays of the recording's .npz, read entry by entry with every header checked before its
    data is read (np.load would allocate a corrupt header's shape, and lets zipfile's and its own
    parser's exceptions through): RecordingError for anything else than what `save` writes."""
    arrays = {}
    try:
        with zipfile.ZipFile(path) as archive:
            names = [info.filename for info in archive.infolist()]
            duplicates = sorted({n for n in names if names.count(n) > 1})
            if duplicates:  # zipfile would read the last one silently
                raise RecordingError(f"{name}: corrupt: two entries named {_short(duplicates[0])}")
            if "meta.npy" not in names:
                raise RecordingError(f"{name}: not a viscera recording (no 'meta' entry; it has "
                                     f"{_short(sorted(n.removesuffix('.npy') for n in names))})")
            for info in archive.infolist():
                key = info.filename.removesuffix(".npy")
                if key not in ENTRIES or not info.filename.endswith(".npy"):
                    raise RecordingError(f"{name}: an entry {_short(info.filename)} that no recording has")
                arrays[key] = _read_entry(archive, info, name, *ENTRIES[key])
    except RecordingError:
        raise
    except Exception as error:  # noqa: BLE001 (any bytes: zipfile's BadZipFile, NotImplementedError, zlib, EOF...)
        raise RecordingError(f"{name}: corrupt or truncated ({_one_line(error)})") from None
    return arrays


def _read_entry(archive: zipfile.ZipFile, info: zipfile.ZipInfo, name: str, dtype: np.dtype, ndim: int,
                max_bytes: int) -> np.ndarray:
    """One .npy entry, its header checked against what `save` writes (dtype, dimensions, C order,
    its data's size) before the data is read."""
    from numpy.lib import format as npy
    key = info.filename.removesuffix(".npy")
    if info.compress_type not in (zipfile.ZIP_STORED, zipfile.ZIP_DEFLATED):  # what numpy writes
        raise RecordingError(f"{name}: corrupt: its {key!r} entry has compression method {info.compress_type} "
                             "(a recording's are stored or deflated)")
    if info.flag_bits & 0x1:
        raise RecordingError(f"{name}: corrupt: its {key!r} entry is encrypted")
    if info.file_size > max_bytes:
        raise RecordingError(f"{name}: corrupt: its {key!r} entry says it is {info.file_size} bytes "
                             f"(at most {max_bytes})")
    with archive.open(info) as entry:
        try:
            version = npy.read_magic(entry)
            read_header = {(1, 0): npy.read_array_header_1_0, (2, 0): npy.read_array_header_2_0}.get(version)
            if read_header is None:
                raise ValueError(f"format version {version}")
            shape, fortran_order, stored = read_header(entry)
        except RecordingError:
            raise
        except Exception as error:  # noqa: BLE001 (numpy's header parser: ValueError, tokenize's TokenError...)
            raise RecordingError(f"{name}: corrupt: its {key!r} entry's .npy header ({_one_line(error)})") from None
        if stored != dtype or len(shape) != ndim or fortran_order:
            raise RecordingError(f"{name}: its {key!r} entry is a {'Fortran-order ' * bool(fortran_order)}"
                                 f"{_short(str(stored), quoted=False)} array of shape {_short(shape)}, "
                                 f"not a {ndim}-D {dtype}")
        size = math.prod(shape) * dtype.itemsize
        data = entry.read(max_bytes + 1)  # to its end: zipfile checks the CRC there
    if len(data) != size:
        raise RecordingError(f"{name}: corrupt: its {key!r} entry's header says shape {_short(shape)}, "
                             f"{_short(size)} bytes of data; it holds {len(data)}")
    return np.frombuffer(bytearray(data), dtype=dtype).reshape(shape)


def _whole_physics_steps(control_timestep_s: float, physics_timestep_s: float) -> bool:
    """Whether dm_control's Environment takes the control period (compute_n_steps: a whole number
    of physics steps, within 1e-8); asked before it is built, on a period already bounded."""
    from dm_control.rl import control
    try:
        control.compute_n_steps(control_timestep_s, physics_timestep_s)
    except ValueError:
        return False
    return True


def _is_int(value) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _short(value, quoted: bool = True, limit: int = 60) -> str:
    """`value` for a one-line message: repr (or str), cut to `limit` characters (a corrupt meta's
    value may be a megabyte)."""
    if _is_int(value) and abs(value) > 10 ** limit:
        return f"an integer of {len(str(abs(value)))} digits"  # str() of 4300+ digits raises ValueError
    text = repr(value) if quoted else " ".join(str(value).split())
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _one_line(error: BaseException) -> str:
    return " ".join(str(error).split()) or type(error).__name__


def final_state_sha256(physics) -> str:
    """SHA-256 (hex) of the mjSTATE_FULLPHYSICS state, as float64 bytes."""
    from viscera.scale.batch import state_of
    return hashlib.sha256(state_of(physics.model.ptr, physics.data.ptr).tobytes()).hexdigest()


def action_width(task: str, scene: str = "abdomen") -> int:
    """The length of `task`'s action (its tools' actuators); its scene is built once per process."""
    return _task_shape(task, scene)[0]


@functools.cache
def _task_shape(task: str, scene: str = "abdomen") -> tuple[int, float, np.ndarray, np.ndarray]:
    """`task`'s action length, physics timestep (s) and action bounds (rad, m) in `scene`; built
    once per process."""
    env = load_task(task, 0, scene=scene)
    spec = env.action_spec()
    low, high = (np.broadcast_to(np.asarray(bound, dtype=np.float64), spec.shape)
                 for bound in (spec.minimum, spec.maximum))
    return int(spec.shape[0]), float(env.physics.timestep()), low, high


def load_task(task: str, seed: int | None, control_timestep_s: float | None = None,
              time_limit_s: float | None = None, scene: str = "abdomen", pixels: dict | None = None):
    """The task's environment; `pixels` ({"height", "width", "camera"}, a policy file's) adds the
    camera's images to its observations (the physics is the same: a replay needs none)."""
    import viscera.tasks
    kwargs = {"scene": scene}
    if pixels is not None:
        kwargs.update(pixels=True, height=pixels["height"], width=pixels["width"], camera=pixels["camera"])
    if control_timestep_s is not None:
        kwargs["control_timestep"] = control_timestep_s
    if time_limit_s is not None:
        kwargs["time_limit"] = time_limit_s
    return viscera.tasks.load(task, seed=seed, **kwargs)


class Recorder:
    """Collects a live session's actions (viscera.teleop.session) into a Recording."""

    def __init__(self, task: str, seed: int | None, policy: str, control_timestep_s: float, time_limit_s: float,
                 policy_seed: int | None = None, scene: str = "abdomen"):
        self.recording = Recording(task, seed, policy, float(control_timestep_s), float(time_limit_s),
                                   np.zeros((0, 0)), policy_seed=policy_seed, created=_now(), versions=versions(),
                                   scene=scene)
        self._actions: list[np.ndarray] = []
        self._camera: list[np.ndarray] = []

    def append(self, action, camera=None) -> None:
        """The tick's action and, where the laparoscope is steered, its pose during the tick."""
        self._actions.append(np.array(action, dtype=np.float64))
        if camera is not None:
            self._camera.append(np.array(camera, dtype=np.float64))

    def finish(self, env) -> Recording:
        recording = self.recording
        count = env.physics.model.nu
        recording.actions = np.array(self._actions, dtype=np.float64).reshape(-1, count)
        if self._camera:
            recording.camera = np.array(self._camera, dtype=np.float64).reshape(-1, 4)
        recording.success = bool(env.task.success(env.physics))
        recording.final_state_sha256 = final_state_sha256(env.physics)
        return recording


def policy_for(env, policy, seed: int | None) -> Callable:
    """The callable (time step -> action) of a policy kind: the task's script, uniform random
    actions within the action spec (numpy's default_rng(seed)), or idle (the tools held where
    the episode starts them: withdrawn, jaws open); or of a policy file (its path, or a
    viscera.policy_file.LearnedPolicy), checked against `env` (a PolicyFileError if it cannot act
    in it)."""
    import viscera.tasks
    from viscera import policy_file
    if isinstance(policy, policy_file.LearnedPolicy) or (policy not in POLICIES and policy_file.is_path(policy)):
        learned = policy if isinstance(policy, policy_file.LearnedPolicy) else policy_file.load(policy)
        learned.check_env(env)
        return learned
    if policy == "scripted":
        return viscera.tasks.scripted_policy(env)
    spec = env.action_spec()
    if policy == "random":
        rng = np.random.default_rng(seed)
        return lambda time_step: rng.uniform(spec.minimum, spec.maximum)
    if policy == "idle":
        hold = np.array(env.physics.data.ctrl, dtype=np.float64)

        def idle(time_step):  # the tools held where the episode's start put them (in view)
            if time_step.first():
                hold[:] = env.physics.data.ctrl
            return hold.copy()
        return idle
    raise ValueError(f"policy {policy!r}: one of {', '.join(POLICIES)}")


def record(task: str, seed: int | None, policy="scripted", time_limit_s: float | None = None,
           control_timestep_s: float | None = None, policy_seed: int | None = None, progress: bool = False,
           on_step: Callable | None = None, scene: str = "abdomen") -> Recording:
    """Run one episode of `task` (seed `seed`, on `scene`) with a policy kind (POLICIES) or a
    policy file (its path, or a viscera.policy_file.LearnedPolicy) and record it. A policy file's
    environment has its control period (unless `control_timestep_s` says another, refused) and
    its pixels; the file is checked against the task, scene and environment before the reset (a
    PolicyFileError). `on_step(env, time_step)` is called after the reset and after every step."""
    from viscera import policy_file
    learned = None
    if isinstance(policy, policy_file.LearnedPolicy) or (policy not in POLICIES and policy_file.is_path(policy)):
        learned = policy if isinstance(policy, policy_file.LearnedPolicy) else policy_file.load(policy)
        learned.check_task(task, scene)
        if control_timestep_s is None:
            control_timestep_s = learned.control_timestep_s
    elif policy not in POLICIES:
        raise ValueError(f"policy {policy!r}: one of {', '.join(POLICIES)}")
    env = load_task(task, seed, control_timestep_s, time_limit_s, scene, learned.pixels if learned else None)
    if learned is not None:
        learned.check_env(env)  # before the first step: the observations and actions it was trained on
    time_step = env.reset()
    if policy == "random" and policy_seed is None:
        policy_seed = seed
    act = learned if learned is not None else policy_for(env, policy, policy_seed)
    recorder = Recorder(task, seed, learned.label if learned is not None else policy, env.control_timestep(),
                        time_limit_s if time_limit_s is not None else env.task.TIME_LIMIT_S, policy_seed, scene)
    _step_through(env, time_step, lambda step: np.asarray(act(step), dtype=np.float64), on_step,
                  _bar(progress, recorder.recording, task), recorder.append)
    return recorder.finish(env)


def _step_through(env, time_step, act: Callable, on_step: Callable | None, bar, record: Callable | None = None) -> int:
    """Step `env` with `act(time_step)`'s actions until it gives None or the episode ends;
    `on_step(env, time_step)` after the reset and every step; `record(action)` before each step.
    Returns the steps taken."""
    if on_step is not None:
        on_step(env, time_step)
    steps = 0
    try:
        while not time_step.last():
            action = act(time_step)
            if action is None:
                break
            if record is not None:
                record(action)
            time_step = env.step(action)
            steps += 1
            if on_step is not None:
                on_step(env, time_step)
            if bar is not None:
                bar.update(1)
    finally:
        if bar is not None:
            bar.close()
    return steps


def _bar(progress: bool, recording: Recording, task: str):
    if not progress:
        return None
    from tqdm import tqdm
    return tqdm(total=int(round(recording.time_limit_s / recording.control_timestep_s)), unit="tick", desc=task)


@dataclasses.dataclass
class ReplayResult:
    final_state_sha256: str
    success: bool
    steps: int
    env: object

    def matches(self, recording: Recording) -> bool:
        return not recording.final_state_sha256 or self.final_state_sha256 == recording.final_state_sha256


def replay(recording: Recording, on_step: Callable | None = None, progress: bool = False) -> ReplayResult:
    """Step the recording's actions through its task again; `on_step(env, time_step)` after the
    reset and every step. Stops early if the episode ends before the actions do."""
    env = load_task(recording.task, recording.seed, recording.control_timestep_s, recording.time_limit_s,
                    recording.scene)
    time_step = env.reset()
    expected = env.action_spec().shape
    if recording.actions.shape[1:] != expected:
        raise RecordingError(f"actions of {recording.actions.shape[1]} values, the task {recording.task!r} takes "
                             f"{expected[0]}")
    actions = iter(recording.actions)
    act = lambda step: next(actions, None)  # noqa: E731
    if recording.camera is not None:
        from viscera.laparoscope import Laparoscope
        scope = Laparoscope.of(env.physics, recording.optics_deg)
        poses = iter(recording.camera)

        def act(step):  # the tick's camera pose, then its action (as the session set them)
            action = next(actions, None)
            if action is not None and scope is not None:
                scope.apply(env.physics, next(poses))
            return action
    steps = _step_through(env, time_step, act, on_step, _bar(progress, recording, recording.task))
    return ReplayResult(final_state_sha256(env.physics), bool(env.task.success(env.physics)), steps, env)


def verdict(task: str, success: bool) -> str:
    """The last line of play, record and replay: success yes or no, against the task's criterion
    (its class's CRITERION)."""
    import viscera.tasks
    criterion = viscera.tasks.base.SUITE.get(task, viscera.tasks.base.BowelTask).CRITERION
    return f"success: {'yes' if success else 'no'} ({task}: {criterion})"


# -- the motion as scripted trajectories (viscera.trajectory)

TOLERANCE = {"deg": 0.05, "m": 0.00005}  # waypoints simplified within 0.05 deg and 0.05 mm


def _simplify(times: np.ndarray, values: np.ndarray, tolerance: np.ndarray) -> list[int]:
    """The ticks to keep as waypoints (ends included) so that ToolTrajectory's quintic between
    consecutive kept ticks passes within `tolerance` (per coordinate) of every tick's value:
    Ramer-Douglas-Peucker with the quintic smoothstep in place of the straight line, on all of a
    tool's coordinates at once (values: (ticks, coordinates))."""
    keep = {0, len(times) - 1}
    stack = [(0, len(times) - 1)]
    while stack:
        first, last = stack.pop()
        if last - first < 2:
            continue
        u = (times[first + 1:last] - times[first]) / (times[last] - times[first])
        ease = (u * u * u * (10.0 + u * (-15.0 + 6.0 * u)))[:, None]
        curve = values[first] + ease * (values[last] - values[first])
        error = np.max(np.abs(values[first + 1:last] - curve) / tolerance, axis=1)
        worst = int(np.argmax(error))
        if error[worst] > 1.0:
            middle = first + 1 + worst
            keep.add(middle)
            stack += [(first, middle), (middle, last)]
    return sorted(keep)


def trajectories(recording: Recording) -> dict[str, dict]:
    """The motion of each tool as a ToolTrajectory JSON object (viscera.trajectory): the command
    of each tick in tool units (deg, m) at the tick's end, kept where ToolTrajectory's easing
    between kept ticks would miss a tick's command by more than TOLERANCE. Played back, the file
    passes within TOLERANCE of every tick's command; between ticks it eases where the recording
    stepped, so a replay from it is close to the recording, not bit for bit. `max_velocity` is set
    above the recording's own speeds so that ToolTrajectory's retiming never stretches it."""
    from viscera.trajectory import COORDINATES, PEAK_SPEED, UNITS
    env = load_task(recording.task, recording.seed, recording.control_timestep_s, recording.time_limit_s)
    model = env.physics.model.ptr
    tools = env.physics.tools()
    dt = recording.control_timestep_s
    times = (np.arange(recording.steps) + 1) * dt  # a tick's command holds until its end
    out = {}
    for tool in tools:
        columns, names = [], []
        for c in COORDINATES:
            a = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, f"{tool}_{c}")
            if a >= 0:
                scale = 1.0 if UNITS[c] == "m" else 180.0 / np.pi
                columns.append(recording.actions[:, a] * scale)
                names.append(c)
        values = np.stack(columns, axis=1) if columns else np.zeros((recording.steps, 0))
        tolerance = np.array([TOLERANCE[UNITS[c]] for c in names])
        rows = _simplify(times, values, tolerance) if recording.steps and names else []
        waypoints = [{"time": 0.0, **dict(zip(names, map(float, values[0])))}] if recording.steps else []
        waypoints += [{"time": float(times[i]), **dict(zip(names, map(float, values[i])))} for i in rows]
        limits = {}
        for c, column in zip(names, columns):
            fastest = float(np.max(np.abs(np.diff(column))) / dt) if len(column) > 1 else 0.0
            limits[c] = max(1e-6, 2.0 * PEAK_SPEED * fastest, 1.0)
        out[tool] = {"waypoints": waypoints, "max_velocity": limits,
                     "source": {"task": recording.task, "seed": recording.seed, "policy": recording.policy}}
    return out
