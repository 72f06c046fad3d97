"""Policy files: a learned policy as one file that anyone can play, record and collect with.

    python -m viscera play grasp_lift --seed 3 --policy grasp_lift_bc.npz     # score and verdict
    policy = viscera.policy_file.load("grasp_lift_bc.npz")   # PolicyFileError (one line) if it is not one
    env = viscera.tasks.load(policy.task, seed=3, scene=policy.scene, **policy.env_kwargs())
    policy.check_env(env)          # the task, scene, observations and actions it was trained on
    action = policy(env.reset())   # time_step -> the dm_env action (rad, m); starts over on time_step.first()

    viscera.policy_file.save("mine.npz", weights={...}, architecture={...}, **viscera.policy_file.describe(env))

A policy file is one `.npz` file (NumPy's zip; written to a temporary name, then renamed, so an
interrupted write never leaves a half file under the name) holding a `meta` entry, UTF-8 JSON
(as a uint8 array), and the network's weights as named float32 or float64 arrays. `meta`:

- `format` ("viscera-policy"), `version` (1);
- `task`, `scene` (the cavity), `control_timestep_s`: the environment the policy acts in; it is
  loaded at that control period;
- `observation`: `state`, the observation entries the policy reads, in its input order, as
  [name, size] pairs (the entries of gymnasium's flat state layout, TaskEnv.observation_layout:
  "intestine_axis" is the flat vector's intestine_axis[0] to [299]); `pixels`, null or
  {"height", "width", "camera"}: the camera's RGB it reads (the environment is then loaded with
  pixels at that size);
- `action`: `size`, `names` (the actuators), `low` and `high` (the dm_env action spec's bounds)
  and `normalisation`: "range" (the network works in gymnasium's normalised actions, -1 and 1 the
  ends of each actuator's range, as TaskEnv maps them) or "none" (in the actuators' own rad and m);
- `architecture`: what the network is, declared (ARCHITECTURE below): the loader refuses
  anything it does not know rather than guess;
- `training`: free-form provenance (data, seeds, updates, losses, the trainer's versions);
- `created`, `viscera`, `mujoco`: when and by which versions it was written (informative).

ARCHITECTURE, version 1: `kind` "mlp", an MLP over the concatenation of its `inputs`, in the
order listed, any of:
- "state": the state entries, `state_normalisation` {"mean": ARRAY, "scale": ARRAY, "clip": C
  (optional)} applied as (state - mean) / scale when given, then clipped to [-C, C] (an entry far
  outside what the network was trained on reaches it no farther than C);
- "clock": the policy's clock, the steps it has taken this episode / `clock_steps` (0 at the first);
- "previous_action": its previous command (in the action's normalisation; zeros before the first,
  `previous_action_start` "zeros");
- "memory": what the network gave as its memory at the step before (`memory` below);
- "pixels": the features of `pixel_encoder` {"scale": S, "layers": [...]} over the RGB / S as
  (3, height, width): each layer {"kind": "conv2d", "weight": ARRAY (out, in, kh, kw), "bias":
  ARRAY (out,), "stride": s, "activation": "relu" or "none"} (no padding), then `pooling`:
  "flatten" (the default: the maps in (channel, row, column) order, as torch's Conv2d and Flatten
  do) or "spatial_softmax" (Levine, Finn, Darrell and Abbeel, JMLR 2016: each channel's softmax
  over its positions, then the expected column and row coordinates, each -1 to 1 from the first
  position's centre to the last's, as (channel, [column, row]): 2 x channels features).
`layers`: [{"kind": "dense", "weight": ARRAY (out, in), "bias": ARRAY (out,), "activation"}, ...];
the last gives `output.chunk` x action size values (then the `memory`'s M, if any). `output`:
`target` "action" (the network gives the command) or "change" (the change from the previous
command, except at the action indices `absolute`, where it gives the command, as a grasper's jaw
jumps), multiplied first by
`scale` (ARRAY (action size,), optional); `held` (optional) {"indices": [...], "values": [...]}:
actions the policy holds at a fixed command (in the action's normalisation) whatever the network
gives, such as an actuator no demonstration moved; `chunk` K >= 1 future commands (row-major: K rows of
the action size), each made a command as above from the command before the chunk and clipped to
the action's range. With K > 1, ACT's temporal ensembling (Zhao et al. 2023): the command at a
step is the average of every chunk's prediction for that step, made at most K - 1 steps earlier,
weighted exp(-m * age) with m = `temporal_ensemble_m`, age 0 for the chunk made at this step (ACT's
own choice, the oldest weighted most with its k = 0.01, is m = -0.01 here). ARRAY is the name of
an array in the file; every array must be used.

`memory` (optional, with "memory" among the inputs): {"size": M, "clip": C}. The last layer gives
M values after the actions: the policy's memory, clipped to [-C, C], which the input "memory"
reads at the next step (zeros at the first). bc.py trains it to say what the oracle was doing
(its phase, the tool that leads, where each tool is going), so that the policy carries its own
plan from step to step.

`residual` (optional): residual policy learning (Silver et al. 2018; Johannink et al., ICRA 2019),
a correction network over the command above: {"inputs": any of "state" (normalised and clipped as
the network reads it), "clock" and "base_action" (the command above), "layers": [dense layers,
as above, the last giving the action size], "scale": S}. The command becomes the command above
plus S times the correction clipped to [-1, 1], the held actions held, clipped to the action's
range; it is the previous command the next step reads.

Inference is NumPy in float64 and bit-identical on any x86-64 CPU whatever SIMD features NumPy
finds there (tested with them disabled): a layer is an elementwise multiply then `.sum(axis=-1)`
over a C-contiguous last axis (NumPy's pairwise sum, whose order does not depend on the CPU), not
`@`, BLAS or einsum; the activations are ReLU (exact); the convolution is NumPy's
sliding_window_view then multiply and sum; the ensembling's weights come from Python's decimal
(integer arithmetic: libm's exp has CPU-dependent variants) and are added in a fixed order; the
spatial softmax's exponentials are a fixed polynomial in elementwise products and sums (_exp_array).
"""

from __future__ import annotations

import collections
import decimal
import hashlib
import io
import json
import math
import os
import pathlib
import re
import zipfile
import zlib

import numpy as np

from viscera import atomic, provenance

FORMAT = "viscera-policy"
VERSION = 1
KINDS = ("mlp",)
INPUTS = ("pixels", "state", "clock", "previous_action", "memory")
ACTIVATIONS = ("relu", "none")
TARGETS = ("action", "change")
POOLINGS = ("flatten", "spatial_softmax")  # a pixel encoder's last step
NORMALISATIONS = ("range", "none")
PREVIOUS_STARTS = ("zeros",)
RESIDUAL_INPUTS = ("state", "clock", "base_action")  # what a residual correction reads
DIGEST_DIGITS = 12  # the SHA-256 prefix in a policy's label
META_KEYS = {"format", "version", "task", "scene", "control_timestep_s", "observation", "action", "architecture",
             "training", "created", "viscera", "mujoco"}
REQUIRED = ("task", "scene", "control_timestep_s", "observation", "action", "architecture")
ARRAY_NAME = re.compile(r"[A-Za-z0-9_.\-]{1,200}")


class PolicyFileError(ValueError):
    """A policy file that cannot be played: one line naming the file and what is wrong."""

    def __init__(self, path, problem: str):
        super().__init__(f"{path}: {problem}")
        self.path, self.problem = str(path), problem

    def __reduce__(self):  # raised in a worker process, it crosses back whole
        return PolicyFileError, (self.path, self.problem)


def is_path(text) -> bool:
    """Whether a --policy value names a file rather than a policy kind: it ends in .npz or holds
    a path separator."""
    if isinstance(text, os.PathLike):
        return True
    text = str(text)
    return text.lower().endswith(".npz") or os.sep in text or bool(os.altsep and os.altsep in text)


# -- reading and checking the meta

class _Reader:
    """Checks of the meta's values, each failure one PolicyFileError naming the file and the key."""

    def __init__(self, path: str, arrays: dict[str, np.ndarray]):
        self.path, self.arrays, self.used = path, arrays, set()

    def fail(self, problem: str):
        raise PolicyFileError(self.path, problem)

    def object(self, value, where: str, required=(), optional=()) -> dict:
        if not isinstance(value, dict):
            self.fail(f"{where} must be a JSON object, got {_short(value)}")
        missing = [k for k in required if k not in value]
        if missing:
            self.fail(f"{where} has no {missing[0]!r}")
        unknown = sorted(set(value) - set(required) - set(optional))
        if unknown:
            self.fail(f"{where} has {unknown[0]!r}, which this viscera does not know (it knows "
                      f"{', '.join(list(required) + list(optional))}): written for a newer viscera?")
        return value

    def choice(self, value, where: str, choices) -> str:
        if value not in choices:
            self.fail(f"{where} {_short(value)} is not one this viscera knows ({', '.join(choices)})")
        return value

    def integer(self, value, where: str, minimum: int = 1) -> int:
        if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
            self.fail(f"{where} {_short(value)} is not an integer of at least {minimum}")
        return value

    def number(self, value, where: str, positive: bool = False) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
                or (positive and value <= 0):
            self.fail(f"{where} {_short(value)} is not a {'positive' if positive else 'finite'} number")
        return float(value)

    def text(self, value, where: str) -> str:
        if not isinstance(value, str) or not value:
            self.fail(f"{where} {_short(value)} is not a name")
        return value

    def numbers(self, value, where: str, size: int) -> np.ndarray:
        if not isinstance(value, list) or len(value) != size:
            self.fail(f"{where} must be a list of {size} numbers")
        return np.array([self.number(v, f"{where}[{i}]") for i, v in enumerate(value)], dtype=np.float64)

    def array(self, reference, where: str, shape: tuple) -> np.ndarray:
        """The array `reference` names, of `shape` (None: any size there), as float64."""
        if not isinstance(reference, str) or reference not in self.arrays:
            self.fail(f"{where} names array {_short(reference)}, which the file does not hold")
        array = self.arrays[reference]
        if len(array.shape) != len(shape) or any(s is not None and s != a for s, a in zip(shape, array.shape)):
            wanted = "(" + ", ".join("any" if s is None else str(s) for s in shape) + ("," if len(shape) == 1 else "") + ")"
            self.fail(f"{where}: array {reference!r} is {array.shape}, it must be {wanted}")
        if array.size == 0:
            self.fail(f"{where}: array {reference!r} is empty")
        self.used.add(reference)
        return np.ascontiguousarray(array, dtype=np.float64)


def _short(value) -> str:
    text = json.dumps(value) if not isinstance(value, np.ndarray) else repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


class _Dense:
    def __init__(self, weight, bias, relu):
        self.weight, self.bias, self.relu = weight, bias, relu

    def __call__(self, x: np.ndarray) -> np.ndarray:
        # elementwise product, then the pairwise sum along the C-contiguous last axis: no BLAS
        y = np.multiply(self.weight, x, order="C").sum(axis=-1) + self.bias
        return np.maximum(y, 0.0) if self.relu else y


class _Conv:
    def __init__(self, weight, bias, stride, relu):
        self.out, self.channels, self.kh, self.kw = weight.shape
        self.weight = np.ascontiguousarray(weight.reshape(self.out, -1))  # (out, in * kh * kw)
        self.bias, self.stride, self.relu = bias, stride, relu

    def size(self, height: int, width: int) -> tuple[int, int]:
        return (height - self.kh) // self.stride + 1, (width - self.kw) // self.stride + 1

    def __call__(self, x: np.ndarray) -> np.ndarray:
        """(in, H, W) -> (out, H', W')."""
        s = self.stride
        windows = np.lib.stride_tricks.sliding_window_view(x, (self.kh, self.kw), axis=(1, 2))[:, ::s, ::s]
        rows, columns = windows.shape[1:3]
        # (H', W', in, kh, kw) made contiguous: each window's values in the weight's order
        patches = np.ascontiguousarray(windows.transpose(1, 2, 0, 3, 4)).reshape(rows * columns, 1, -1)
        y = np.multiply(patches, self.weight, order="C").sum(axis=-1) + self.bias  # (H' W', out)
        if self.relu:
            y = np.maximum(y, 0.0)
        return np.ascontiguousarray(y.T).reshape(self.out, rows, columns)


def _check(meta, arrays: dict[str, np.ndarray], path: str) -> dict:
    """The meta and arrays checked against each other: what inference needs, or PolicyFileError."""
    r = _Reader(path, arrays)
    if not isinstance(meta, dict):
        r.fail(f"not a viscera policy (its meta is {type(meta).__name__}, not a JSON object)")
    if meta.get("format") != FORMAT:
        if meta.get("format") == "viscera-recording":
            r.fail("a viscera recording, not a policy (python -m viscera replay plays it)")
        r.fail(f"not a viscera policy (format {_short(meta.get('format'))})")
    version = meta.get("version")
    if isinstance(version, bool) or not isinstance(version, int) or version < 1:
        r.fail(f"bad format version {_short(version)}")
    if version > VERSION:
        r.fail(f"format version {version} is newer than this viscera reads ({VERSION}): upgrade viscera")
    r.object(meta, "its meta", ("format", "version") + REQUIRED, sorted(META_KEYS - set(REQUIRED) - {"format", "version"}))
    from viscera.task_registry import TASKS  # the names, without loading dm_control
    task = r.text(meta["task"], "task")
    if task not in TASKS:
        r.fail(f"unknown task {task!r}; known: {', '.join(TASKS)}")
    scene = r.text(meta["scene"], "scene")
    from viscera.tasks.scene import SCENES
    if scene not in SCENES:
        r.fail(f"unknown scene {scene!r}; known: {', '.join(SCENES)}")
    control_timestep_s = r.number(meta["control_timestep_s"], "control_timestep_s", positive=True)

    observation = r.object(meta["observation"], "observation", ("state", "pixels"))
    state = observation["state"]
    if not isinstance(state, list):
        r.fail("observation.state must be a list of [name, size] pairs")
    entries = collections.OrderedDict()
    for i, entry in enumerate(state):
        if not isinstance(entry, list) or len(entry) != 2:
            r.fail(f"observation.state[{i}] must be a [name, size] pair, got {_short(entry)}")
        name = r.text(entry[0], f"observation.state[{i}]'s name")
        if name in entries:
            r.fail(f"observation.state lists {name!r} twice")
        if name in ("pixels", "depth", "segmentation"):
            r.fail(f"observation.state lists the image {name!r}: images go in observation.pixels")
        entries[name] = r.integer(entry[1], f"observation.state {name!r}'s size")
    state_size = sum(entries.values())
    pixels = observation["pixels"]
    if pixels is not None:
        r.object(pixels, "observation.pixels", ("height", "width", "camera"))
        pixels = {"height": r.integer(pixels["height"], "observation.pixels.height"),
                  "width": r.integer(pixels["width"], "observation.pixels.width"),
                  "camera": r.text(pixels["camera"], "observation.pixels.camera")}
        if pixels["height"] > 4096 or pixels["width"] > 4096:
            r.fail(f"observation.pixels {pixels['height']}x{pixels['width']}: at most 4096 x 4096")

    action = r.object(meta["action"], "action", ("size", "names", "low", "high", "normalisation"))
    size = r.integer(action["size"], "action.size")
    names = action["names"]
    if not isinstance(names, list) or len(names) != size or not all(isinstance(n, str) and n for n in names):
        r.fail(f"action.names must be a list of {size} actuator names")
    low, high = r.numbers(action["low"], "action.low", size), r.numbers(action["high"], "action.high", size)
    if not np.all(low < high):
        r.fail("action.low must be below action.high for every actuator")
    normalisation = r.choice(action["normalisation"], "action.normalisation", NORMALISATIONS)

    a = r.object(meta["architecture"], "architecture", ("kind", "inputs", "layers", "output"),
                 ("state_normalisation", "clock_steps", "previous_action_start", "pixel_encoder", "residual",
                  "memory"))
    r.choice(a["kind"], "architecture.kind", KINDS)
    inputs = a["inputs"]
    if not isinstance(inputs, list) or not inputs:
        r.fail("architecture.inputs must be a non-empty list")
    for name in inputs:
        r.choice(name, "architecture.inputs entry", INPUTS)
    if len(set(inputs)) != len(inputs):
        r.fail("architecture.inputs lists an input twice")
    if ("state" in inputs) != bool(entries):
        r.fail("observation.state lists entries its inputs do not read" if entries else
               "architecture.inputs has 'state' but observation.state lists no entry")
    if ("pixels" in inputs) != (pixels is not None):
        r.fail("observation.pixels is given but the inputs do not read pixels" if pixels is not None else
               "architecture.inputs has 'pixels' but observation.pixels is null")
    mean = scale = state_clip = None
    if a.get("state_normalisation") is not None:
        if "state" not in inputs:
            r.fail("architecture.state_normalisation without 'state' in the inputs")
        norm = r.object(a["state_normalisation"], "architecture.state_normalisation", ("mean", "scale"), ("clip",))
        mean = r.array(norm["mean"], "state_normalisation.mean", (state_size,))
        scale = r.array(norm["scale"], "state_normalisation.scale", (state_size,))
        if not np.all(scale > 0):
            r.fail("state_normalisation.scale must be positive")
        if norm.get("clip") is not None:
            state_clip = r.number(norm["clip"], "state_normalisation.clip", positive=True)
    clock_steps = None
    if "clock" in inputs:
        if a.get("clock_steps") is None:
            r.fail("architecture.inputs has 'clock' but no clock_steps")
        clock_steps = r.integer(a["clock_steps"], "architecture.clock_steps")
    elif a.get("clock_steps") is not None:
        r.fail("architecture.clock_steps without 'clock' in the inputs")
    r.choice(a.get("previous_action_start", "zeros"), "architecture.previous_action_start", PREVIOUS_STARTS)

    encoder = []
    pixel_scale = None
    features = 0
    if "pixels" in inputs:
        if a.get("pixel_encoder") is None:
            r.fail("architecture.inputs has 'pixels' but no pixel_encoder")
        e = r.object(a["pixel_encoder"], "architecture.pixel_encoder", ("scale", "layers"), ("pooling",))
        pooling = r.choice(e.get("pooling", "flatten"), "pixel_encoder.pooling", POOLINGS)
        pixel_scale = r.number(e["scale"], "pixel_encoder.scale", positive=True)
        if not isinstance(e["layers"], list) or not e["layers"]:
            r.fail("pixel_encoder.layers must be a non-empty list")
        channels, height, width = 3, pixels["height"], pixels["width"]
        for i, layer in enumerate(e["layers"]):
            where = f"pixel_encoder.layers[{i}]"
            r.object(layer, where, ("kind", "weight", "bias", "stride", "activation"))
            r.choice(layer["kind"], f"{where}.kind", ("conv2d",))
            weight = r.array(layer["weight"], f"{where}.weight", (None, channels, None, None))
            bias = r.array(layer["bias"], f"{where}.bias", (weight.shape[0],))
            conv = _Conv(weight, bias, r.integer(layer["stride"], f"{where}.stride"),
                         r.choice(layer["activation"], f"{where}.activation", ACTIVATIONS) == "relu")
            if conv.kh > height or conv.kw > width:
                r.fail(f"{where}: a {conv.kh}x{conv.kw} kernel on a {height}x{width} image")
            height, width = conv.size(height, width)
            channels = conv.out
            encoder.append(conv)
        features = channels * height * width if pooling == "flatten" else 2 * channels
        if pooling == "spatial_softmax":
            encoder.append(_SpatialSoftmax(height, width))
    elif a.get("pixel_encoder") is not None:
        r.fail("architecture.pixel_encoder without 'pixels' in the inputs")

    o = r.object(a["output"], "architecture.output", ("target",),
                 ("scale", "absolute", "chunk", "temporal_ensemble_m", "held"))
    target = r.choice(o["target"], "output.target", TARGETS)
    output_scale = r.array(o["scale"], "output.scale", (size,)) if o.get("scale") is not None else None
    absolute = o.get("absolute", [])
    if not isinstance(absolute, list) or any(isinstance(i, bool) or not isinstance(i, int) or not 0 <= i < size
                                             for i in absolute):
        r.fail(f"output.absolute must be a list of action indices (0 to {size - 1})")
    if absolute and target != "change":
        r.fail("output.absolute is for the target 'change'")
    mask = np.zeros(size, dtype=bool)
    mask[absolute] = True
    held_mask, held_values = np.zeros(size, dtype=bool), np.zeros(size)
    if o.get("held") is not None:
        held = r.object(o["held"], "output.held", ("indices", "values"))
        indices, values = held["indices"], held["values"]
        if (not isinstance(indices, list) or not isinstance(values, list) or len(indices) != len(values) or
                any(isinstance(i, bool) or not isinstance(i, int) or not 0 <= i < size for i in indices) or
                len(set(indices)) != len(indices)):
            r.fail(f"output.held must give distinct action indices (0 to {size - 1}) and as many values")
        for i, value in zip(indices, values):
            held_mask[i] = True
            held_values[i] = r.number(value, f"output.held.values[{i}]")
    chunk = r.integer(o.get("chunk", 1), "output.chunk")
    m = o.get("temporal_ensemble_m")
    if chunk > 1:
        if m is None:
            r.fail(f"output.chunk {chunk} needs temporal_ensemble_m")
        m = r.number(m, "output.temporal_ensemble_m")
    elif m is not None:
        r.fail("output.temporal_ensemble_m is for a chunk of more than one action")
    try:
        weights = [_exp(-m * age) for age in range(chunk)] if chunk > 1 else [1.0]
    except ArithmeticError:
        weights = [math.inf]
    if not all(math.isfinite(w) and w > 0 for w in weights):
        r.fail(f"output.temporal_ensemble_m {m!r} gives weights that are not finite and positive")

    memory_size, memory_clip = 0, None
    if "memory" in inputs:
        if a.get("memory") is None:
            r.fail("architecture.inputs has 'memory' but no architecture.memory")
        e = r.object(a["memory"], "architecture.memory", ("size", "clip"))
        memory_size = r.integer(e["size"], "memory.size")
        memory_clip = r.number(e["clip"], "memory.clip", positive=True)
    elif a.get("memory") is not None:
        r.fail("architecture.memory without 'memory' in the inputs")
    width = sum({"pixels": features, "state": state_size, "clock": 1, "previous_action": size,
                 "memory": memory_size}[k] for k in inputs)
    dense, width = _dense_layers(r, a["layers"], "architecture.layers", width)
    if width != chunk * size + memory_size:
        r.fail(f"the last layer gives {width} values; a chunk of {chunk} actions of {size} takes {chunk * size}"
               + (f", and the memory {memory_size} more" if memory_size else ""))
    residual = None
    if a.get("residual") is not None:
        residual = _check_residual(r, a["residual"], inputs, state_size, size)
    unused = sorted(set(arrays) - r.used)
    if unused:
        r.fail(f"holds array {unused[0]!r}, which its architecture does not use")
    for name in sorted(r.used):
        if not np.all(np.isfinite(arrays[name])):
            r.fail(f"array {name!r} holds NaN or infinite values")
    return {"task": task, "scene": scene, "control_timestep_s": control_timestep_s, "entries": entries,
            "state_size": state_size, "pixels": pixels, "size": size, "names": names, "low": low, "high": high,
            "normalisation": normalisation, "inputs": inputs, "mean": mean, "scale": scale, "state_clip": state_clip,
            "clock_steps": clock_steps, "pixel_scale": pixel_scale, "encoder": encoder, "dense": dense,
            "target": target, "output_scale": output_scale, "absolute": mask, "held": held_mask,
            "held_values": held_values, "chunk": chunk, "m": m,
            "ensemble_weights": weights, "residual": residual, "memory_size": memory_size,
            "memory_clip": memory_clip}


def _dense_layers(r: _Reader, layers, where: str, width: int) -> tuple[list, int]:
    """`layers` (a list of dense layers over `width` inputs, at `where`) and the width they give."""
    if not isinstance(layers, list) or not layers:
        r.fail(f"{where} must be a non-empty list")
    dense = []
    for i, layer in enumerate(layers):
        at = f"{where}[{i}]"
        r.object(layer, at, ("kind", "weight", "bias", "activation"))
        r.choice(layer["kind"], f"{at}.kind", ("dense",))
        weight = r.array(layer["weight"], f"{at}.weight", (None, width))
        bias = r.array(layer["bias"], f"{at}.bias", (weight.shape[0],))
        dense.append(_Dense(weight, bias, r.choice(layer["activation"], f"{at}.activation", ACTIVATIONS) == "relu"))
        width = weight.shape[0]
    return dense, width


def _check_residual(r: _Reader, value, inputs: list, state_size: int, size: int) -> dict:
    """architecture.residual: a correction network added to the command (residual policy learning)."""
    e = r.object(value, "architecture.residual", ("inputs", "layers", "scale"))
    read = e["inputs"]
    if not isinstance(read, list) or not read or len(set(map(str, read))) != len(read):
        r.fail("residual.inputs must be a non-empty list without repeats")
    for name in read:
        r.choice(name, "residual.inputs entry", RESIDUAL_INPUTS)
    if "state" in read and "state" not in inputs:
        r.fail("residual.inputs has 'state' but the policy's inputs do not")
    if "clock" in read and "clock" not in inputs:
        r.fail("residual.inputs has 'clock' but the policy's inputs do not (no clock_steps)")
    width = sum({"state": state_size, "clock": 1, "base_action": size}[k] for k in read)
    dense, width = _dense_layers(r, e["layers"], "residual.layers", width)
    if width != size:
        r.fail(f"residual.layers give {width} values; the action has {size}")
    return {"inputs": read, "dense": dense, "scale": r.number(e["scale"], "residual.scale", positive=True)}


class _SpatialSoftmax:
    """(C, H, W) maps -> (2 C,) features: per channel, the softmax over the H x W positions, then
    the expected column and row coordinates (each -1 to 1 across the map)."""

    def __init__(self, height: int, width: int):
        columns = np.linspace(-1.0, 1.0, width) if width > 1 else np.zeros(1)
        rows = np.linspace(-1.0, 1.0, height) if height > 1 else np.zeros(1)
        self.coordinates = np.stack([np.tile(columns, height), np.repeat(rows, width)])[None]  # (1, 2, H W)

    def __call__(self, x: np.ndarray) -> np.ndarray:
        flat = x.reshape(x.shape[0], -1)
        weights = _exp_array(flat - flat.max(axis=1, keepdims=True))
        weights = weights / weights.sum(axis=1, keepdims=True)
        return np.multiply(weights[:, None, :], self.coordinates, order="C").sum(axis=-1).ravel()


_LN2_HIGH, _LN2_LOW = 6.93147180369123816490e-01, 1.90821492927058770002e-10  # fdlibm's split of ln 2
_EXP_TERMS = [1.0 / math.factorial(n) for n in range(14, -1, -1)]  # Taylor's, highest first


def _exp_array(x: np.ndarray) -> np.ndarray:
    """e^x elementwise for x <= 0, within 2e-16 relative: x = k ln 2 + r with |r| <= ln 2 / 2,
    e^r by Horner's rule on its Taylor polynomial (degree 14), times 2^k exactly (ldexp). Only
    elementwise IEEE products and sums: the same bits whatever SIMD NumPy uses, where np.exp's
    vectorised kernels differ by CPU."""
    x = np.asarray(x, dtype=np.float64)
    underflow = x < -745.2  # e^x rounds to 0 in float64 below about -745.13
    x = np.maximum(x, -745.2)
    k = np.rint(x / _LN2_HIGH)
    r = (x - k * _LN2_HIGH) - k * _LN2_LOW
    p = np.full_like(r, _EXP_TERMS[0])
    for term in _EXP_TERMS[1:]:
        p = p * r + term
    return np.where(underflow, 0.0, np.ldexp(p, k.astype(np.int64)))


def _exp(x: float) -> float:
    """e^x as the float nearest the exact value: decimal's exp (integer arithmetic, 40 digits), the
    same on every CPU, where libm's exp has variants that differ in the last bit (FMA or not)."""
    return float(decimal.Context(prec=40).exp(decimal.Decimal(x)))


# -- the policy

class LearnedPolicy:
    """A policy file's policy: `policy(time_step) -> action`, as the scripted policies are (the
    dm_env action: the actuators' controls in rad and m). It remembers its clock, its previous
    command and, with action chunks, the chunks it predicted; a FIRST time step starts it over."""

    def __init__(self, path: str, meta: dict, weights: dict[str, np.ndarray], sha256: str):
        self.path, self.meta, self.weights, self.sha256 = str(path), meta, weights, sha256
        self._net = _check(meta, weights, self.path)
        for key in ("task", "scene", "control_timestep_s", "pixels"):
            setattr(self, key, self._net[key])
        self.action_size = self._net["size"]
        self.state_entries = list(self._net["entries"].items())   # [(name, size)] in input order
        if self._net["normalisation"] == "range":
            self._low, self._high = -np.ones(self.action_size), np.ones(self.action_size)
        else:
            self._low, self._high = self._net["low"], self._net["high"]
        self.reset()

    @property
    def name(self) -> str:
        return pathlib.Path(self.path).name

    @property
    def label(self) -> str:
        """How a recording names the policy: file:<file name>#<SHA-256 prefix of the file>."""
        return f"file:{self.name}#{self.sha256[:DIGEST_DIGITS]}"

    @property
    def fields(self) -> dict:
        """The meta's fields as save() takes them (without format, version and the informative ones)."""
        return {k: v for k, v in self.meta.items() if k in REQUIRED or k == "training"}

    def env_kwargs(self) -> dict:
        """viscera.tasks.load's arguments for the environment it acts in: its control period and,
        if it reads pixels, the camera and image size."""
        kwargs = {"control_timestep": self.control_timestep_s}
        if self.pixels is not None:
            kwargs.update(pixels=True, height=self.pixels["height"], width=self.pixels["width"],
                          camera=self.pixels["camera"])
        return kwargs

    def fail(self, problem: str):
        raise PolicyFileError(self.path, problem)

    def check_task(self, task: str, scene: str = "abdomen") -> None:
        """That the policy was trained on `task` in `scene`."""
        if task != self.task:
            self.fail(f"a policy for {self.task}, not {task}")
        if scene != self.scene:
            self.fail(f"a policy for the {self.scene} scene, not {scene} (--scene {self.scene})")

    def check_env(self, env) -> None:
        """That the dm_env environment `env` is one the policy can act in: its task, scene and
        control period, the state entries it reads with their sizes, its pixels, its actuators
        and their ranges. Refused before the environment steps, by a PolicyFileError."""
        task = env.task
        self.check_task(getattr(task, "NAME", None), task.scene.name)
        if not math.isclose(env.control_timestep(), self.control_timestep_s, rel_tol=1e-9):
            self.fail(f"trained at {self.control_timestep_s * 1e3:g} ms control ticks, the environment's are "
                      f"{env.control_timestep() * 1e3:g} ms")
        spec = env.observation_spec()
        for name, size in self.state_entries:
            if name not in spec:
                self.fail(f"reads the observation {name!r}, which {self.task}'s observation has not "
                          f"(it has {', '.join(k for k in spec if k not in ('pixels', 'depth', 'segmentation'))})")
            have = int(np.prod(spec[name].shape))
            if have != size:
                self.fail(f"reads the observation {name!r} as {size} values, {self.task}'s has {have}: "
                          "another observation layout")
        if self.pixels is not None:
            shape = (self.pixels["height"], self.pixels["width"], 3)
            camera = getattr(getattr(task, "camera", None), "camera", None)
            if "pixels" not in spec or tuple(spec["pixels"].shape) != shape or camera != self.pixels["camera"]:
                have = f"{spec['pixels'].shape[0]}x{spec['pixels'].shape[1]} from {camera}" if "pixels" in spec \
                    else "none"
                self.fail(f"reads {shape[0]}x{shape[1]} pixels from the {self.pixels['camera']} camera; the "
                          f"environment gives {have}")
        action = env.action_spec()
        if action.shape != (self.action_size,):
            self.fail(f"gives actions of {self.action_size} values, {self.task} takes {action.shape[0]}")
        names = list(env.physics.named.data.ctrl.axes.row.names)
        if names != list(self._net["names"]):
            self.fail(f"drives the actuators {', '.join(self._net['names'])}; the environment has {', '.join(names)}")
        low = np.broadcast_to(action.minimum, action.shape)
        high = np.broadcast_to(action.maximum, action.shape)
        if not (np.array_equal(low, self._net["low"]) and np.array_equal(high, self._net["high"])):
            self.fail("its actuators' ranges differ from the environment's: another action normalisation")

    # -- acting

    def reset(self) -> None:
        """Start an episode: the clock at 0, the previous command zeros, no chunk."""
        self._steps = 0
        self._previous = np.zeros(self.action_size)
        self._memory = np.zeros(self._net["memory_size"])
        self._chunks: collections.deque = collections.deque(maxlen=self._net["chunk"])

    def state_of(self, observation) -> np.ndarray:
        """The state entries the policy reads, from a dm_env observation, as one float64 vector."""
        if not self.state_entries:
            return np.zeros(0)
        return np.concatenate([np.asarray(observation[name], dtype=np.float64).ravel()
                               for name, _ in self.state_entries])

    def normalised_state(self, state: np.ndarray) -> np.ndarray:
        """The state entries as the network reads them: normalised and clipped as the file says."""
        net = self._net
        x = np.asarray(state, dtype=np.float64)
        if x.shape != (net["state_size"],):
            raise ValueError(f"state of shape {x.shape}, the policy reads {net['state_size']} values")
        if net["mean"] is not None:
            x = (x - net["mean"]) / net["scale"]
            if net["state_clip"] is not None:
                x = np.clip(x, -net["state_clip"], net["state_clip"])
        return x

    @property
    def clock(self) -> float:
        """The clock the next act() reads: steps taken this episode / clock_steps (0 without a clock)."""
        return self._steps / self._net["clock_steps"] if self._net["clock_steps"] else 0.0

    def correction_inputs(self, state: np.ndarray | None, clock: float, base: np.ndarray,
                          inputs=None) -> np.ndarray:
        """What a residual correction reads, in the order of `inputs` (default: the file's
        residual's, else RESIDUAL_INPUTS): the state as the network reads it, the clock and the
        base command `base`. A residual learner trains on exactly these (rl_grasp_lift.py)."""
        residual = self._net["residual"]
        inputs = inputs if inputs is not None else residual["inputs"] if residual is not None else RESIDUAL_INPUTS
        parts = {"state": lambda: self.normalised_state(state), "clock": lambda: np.array([clock], dtype=np.float64),
                 "base_action": lambda: np.asarray(base, dtype=np.float64)}
        return np.concatenate([parts[name]() for name in inputs])

    def corrected(self, base: np.ndarray, correction: np.ndarray, scale: float) -> np.ndarray:
        """The base command plus `scale` times `correction` clipped to [-1, 1], the held actions
        held, clipped to the action's range: what a residual policy commands."""
        net = self._net
        command = np.asarray(base, dtype=np.float64) + scale * np.clip(correction, -1.0, 1.0)
        return np.clip(np.where(net["held"], net["held_values"], command), self._low, self._high)

    def correction(self, state: np.ndarray | None, clock: float, base: np.ndarray) -> np.ndarray:
        """The residual network's raw correction to the base command `base` (corrected() clips
        it): a pure function of its inputs. Zeros for a policy without a residual."""
        residual = self._net["residual"]
        if residual is None:
            return np.zeros(self.action_size)
        x = self.correction_inputs(state, clock, base)
        for layer in residual["dense"]:
            x = layer(x)
        return x

    def network(self, state: np.ndarray | None, clock: float, previous: np.ndarray,
                pixels: np.ndarray | None = None, memory: np.ndarray | None = None) -> np.ndarray:
        """The network's raw actions, (chunk, action size) float64: a pure function of its inputs."""
        return self.network_outputs(state, clock, previous, pixels, memory)[0]

    def network_outputs(self, state: np.ndarray | None, clock: float, previous: np.ndarray,
                        pixels: np.ndarray | None = None,
                        memory: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """The network's raw actions (chunk, action size) and its next memory (clipped), float64:
        a pure function of its inputs (`memory`: the one it gave at the step before, zeros at the first)."""
        net = self._net
        parts = []
        for name in net["inputs"]:
            if name == "state":
                parts.append(self.normalised_state(state))
            elif name == "clock":
                parts.append(np.array([clock], dtype=np.float64))
            elif name == "previous_action":
                parts.append(np.asarray(previous, dtype=np.float64))
            elif name == "memory":
                given = np.zeros(net["memory_size"]) if memory is None else np.asarray(memory, dtype=np.float64)
                if given.shape != (net["memory_size"],):
                    raise ValueError(f"memory of shape {given.shape}, the policy keeps {net['memory_size']} values")
                parts.append(given)
            else:
                image = np.asarray(pixels)
                shape = (self.pixels["height"], self.pixels["width"], 3)
                if image.shape != shape:
                    raise ValueError(f"pixels of shape {image.shape}, the policy reads {shape}")
                x = np.ascontiguousarray(image.transpose(2, 0, 1), dtype=np.float64) / net["pixel_scale"]
                for layer in net["encoder"]:
                    x = layer(x)
                parts.append(x.ravel())
        x = np.concatenate(parts)
        for layer in net["dense"]:
            x = layer(x)
        actions = net["chunk"] * self.action_size
        memory = np.clip(x[actions:], -net["memory_clip"], net["memory_clip"]) if net["memory_size"] else x[actions:]
        return x[:actions].reshape(net["chunk"], self.action_size), memory

    def act(self, state: np.ndarray | None, pixels: np.ndarray | None = None) -> np.ndarray:
        """The next command in the action's normalisation (clipped to its range), from the state
        entries (state_of) and the RGB; advances the clock and remembers the command."""
        net = self._net
        clock = self.clock
        raw, self._memory = self.network_outputs(state, clock, self._previous, pixels, self._memory)
        if net["output_scale"] is not None:
            raw = raw * net["output_scale"]
        if net["target"] == "change":
            raw = np.where(net["absolute"], raw, self._previous + raw)
        raw = np.where(net["held"], net["held_values"], raw)
        predicted = np.clip(raw, self._low, self._high)
        self._chunks.append((self._steps, predicted))
        if net["chunk"] == 1:
            command = predicted[0]
        else:  # ACT's temporal ensembling, the chunks added oldest first
            total, command = 0.0, np.zeros(self.action_size)
            for made, chunk in self._chunks:
                age = self._steps - made
                weight = net["ensemble_weights"][age]
                command = command + weight * chunk[age]
                total += weight
            command = np.clip(command / total, self._low, self._high)
        if net["residual"] is not None:
            command = self.corrected(command, self.correction(state, clock, command), net["residual"]["scale"])
        self._previous = command
        self._steps += 1
        return command.copy()

    def executed(self, command: np.ndarray) -> None:
        """The command the last step actually executed, when another than act's (a residual
        learner's correction added to it): the policy's next input is what was done."""
        command = np.asarray(command, dtype=np.float64)
        if command.shape != (self.action_size,):
            raise ValueError(f"command of shape {command.shape}: the policy's actions are ({self.action_size},)")
        self._previous = np.clip(command, self._low, self._high)

    def dm_action(self, command: np.ndarray) -> np.ndarray:
        """The dm_env action of a command (TaskEnv.dm_action's map for normalised commands)."""
        if self._net["normalisation"] == "none":
            return np.array(command, dtype=np.float64)
        low, high = self._net["low"], self._net["high"]
        return low + 0.5 * (np.clip(command, -1.0, 1.0) + 1.0) * (high - low)

    def __call__(self, time_step) -> np.ndarray:
        if time_step.first():
            self.reset()
        observation = time_step.observation
        pixels = observation["pixels"] if self.pixels is not None else None
        return self.dm_action(self.act(self.state_of(observation), pixels))


# -- files

def load(path: str | os.PathLike) -> LearnedPolicy:
    """The policy in `path`; PolicyFileError (one line naming the file) for anything wrong with it."""
    name = str(path)
    if not os.path.exists(path):
        raise PolicyFileError(name, "no such file")
    if os.path.isdir(path):
        raise PolicyFileError(name, "a folder, not a policy file")
    try:
        with open(path, "rb") as file:
            data = file.read()
    except OSError as error:
        raise PolicyFileError(name, f"cannot be read ({error.strerror or error})") from None
    if not zipfile.is_zipfile(io.BytesIO(data)):
        if data[:4] == b"PK\x03\x04":  # a zip's first entry, its directory at the end gone: cut short
            raise PolicyFileError(name, "truncated (the .npz file ends before its zip directory)")
        raise PolicyFileError(name, "not a viscera policy (not an .npz file)")
    try:
        with np.load(io.BytesIO(data), allow_pickle=False) as archive:
            if "meta" not in archive.files:
                raise PolicyFileError(name, f"not a viscera policy (no 'meta' entry; it has {sorted(archive.files)[:5]})")
            arrays = {key: archive[key] for key in archive.files}
    except PolicyFileError:
        raise
    except (zipfile.BadZipFile, zlib.error, EOFError, OSError, ValueError, KeyError) as error:  # truncated, CRC, pickles
        raise PolicyFileError(name, f"corrupt or truncated ({' '.join(str(error).split()) or type(error).__name__})") \
            from None
    meta_bytes = arrays.pop("meta")
    try:
        meta = json.loads(bytes(np.asarray(meta_bytes, dtype=np.uint8)).decode())
    except (ValueError, UnicodeDecodeError, TypeError):
        raise PolicyFileError(name, "corrupt: its 'meta' entry is not UTF-8 JSON") from None
    for key, array in arrays.items():
        if array.dtype not in (np.float32, np.float64):
            raise PolicyFileError(name, f"array {key!r} is {array.dtype}, not float32 or float64")
    return LearnedPolicy(name, meta, arrays, hashlib.sha256(data).hexdigest())


def save(path: str | os.PathLike, *, weights: dict, task: str, scene: str, control_timestep_s: float,
         observation: dict, action: dict, architecture: dict, training: dict | None = None) -> LearnedPolicy:
    """Write a policy file to `path` (.npz; never a half file under that name) and return it
    loaded. The fields are the meta's (the module doc); `weights` the named float arrays (kept
    float32 if given so, else float64). It is checked as load() checks it first: a
    PolicyFileError names what is wrong, and nothing is written."""
    path = pathlib.Path(path)
    meta = {"format": FORMAT, "version": VERSION, "task": task, "scene": scene,
            "control_timestep_s": control_timestep_s, "observation": observation, "action": action,
            "architecture": architecture}
    if training is not None:
        meta["training"] = training
    meta.update(created=provenance.now(), **provenance.versions())
    try:
        meta = json.loads(json.dumps(meta, allow_nan=False))  # as load() will read it: lists, not tuples
    except (TypeError, ValueError) as error:
        raise PolicyFileError(path, f"its meta is not JSON ({error})") from None
    arrays = {}
    for key, value in weights.items():
        if not isinstance(key, str) or key == "meta" or not ARRAY_NAME.fullmatch(key):
            raise PolicyFileError(path, f"array name {key!r}: letters, digits, _ . - only, and not 'meta'")
        value = np.asarray(value)
        arrays[key] = np.ascontiguousarray(value, dtype=np.float32 if value.dtype == np.float32 else np.float64)
    _check(meta, arrays, str(path))
    atomic.save_npz(path, meta=np.frombuffer(json.dumps(meta).encode(), dtype=np.uint8), **arrays)
    return load(path)


def describe(env, state: list[str] | None = None, pixels: bool = False) -> dict:
    """save()'s environment fields for the dm_env environment `env` (a TaskEnv's `dm_env`): its
    task, scene and control period, the state entries `state` (default: all but the images) with
    their sizes, its camera's RGB if `pixels`, and its actuators with their ranges (normalisation
    "range")."""
    spec = env.observation_spec()
    keys = state if state is not None else [k for k in spec if k not in ("pixels", "depth", "segmentation")]
    action = env.action_spec()
    camera = getattr(env.task, "camera", None)
    if pixels and camera is None:
        raise ValueError("pixels=True: the environment observes no pixels (viscera.tasks.load(..., pixels=True))")
    return {"task": env.task.NAME, "scene": env.task.scene.name, "control_timestep_s": float(env.control_timestep()),
            "observation": {"state": [[k, int(np.prod(spec[k].shape))] for k in keys],
                            "pixels": {"height": camera.height, "width": camera.width, "camera": camera.camera}
                            if pixels else None},
            "action": {"size": int(action.shape[0]), "names": list(env.physics.named.data.ctrl.axes.row.names),
                       "low": [float(v) for v in np.broadcast_to(action.minimum, action.shape)],
                       "high": [float(v) for v in np.broadcast_to(action.maximum, action.shape)],
                       "normalisation": "range"}}
