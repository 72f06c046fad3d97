"""Argument checks shared by the Python layers: refuse bad input by name before it reaches MuJoCo."""

from __future__ import annotations

import mujoco
import numpy as np


def finite_array(name: str, value, shape: tuple) -> np.ndarray:
    """`value` as a C-contiguous float64 array of `shape` (None: any size there), all finite.

    Raises ValueError naming `name`, and the shape or the first non-finite entry and its value.
    """
    try:
        array = np.ascontiguousarray(value, dtype=np.float64)
    except (TypeError, ValueError) as error:
        raise ValueError(f"{name} = {value!r}: not an array of numbers ({error})") from None
    if array.ndim != len(shape) or any(want is not None and got != want for got, want in zip(array.shape, shape)):
        expected = "(" + ", ".join("any" if s is None else str(s) for s in shape) + ")"
        raise ValueError(f"{name} has shape {array.shape}, expected {expected}")
    bad = np.argwhere(~np.isfinite(array))
    if len(bad):
        index = tuple(int(i) for i in bad[0])
        raise ValueError(f"{name}{list(index)} = {float(array[index])}: must be finite")
    return array


def checked_integer(name: str, value, minimum: int) -> int:
    """`value` as an int, refused by name unless it is an integer of at least `minimum`."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise ValueError(f"{name} = {value!r}: must be an integer")
    if value < minimum:
        raise ValueError(f"{name} = {value}: must be at least {minimum}")
    return int(value)


def checked_bool(name: str, value) -> bool:
    """`value` as a bool, refused by name unless it is True or False (Python's or numpy's)."""
    if not isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{name} = {value!r}: must be True or False")
    return bool(value)


def camera_id(model: mujoco.MjModel, camera: int | str) -> int:
    """The id of the model's camera `camera`: a name, an id, or an id written as digits (a name wins).

    Raises ValueError naming `camera` and listing the cameras there are.
    """
    names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_CAMERA, i) or f"#{i}" for i in range(model.ncam)]
    listing = f"its cameras: {', '.join(names)}" if names else "it has no cameras"
    if isinstance(camera, str):
        index = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, camera)
        if index >= 0:
            return index
        if not camera.isdigit():
            raise ValueError(f"no camera named {camera!r} in the scene; {listing}")
        camera = int(camera)
    if isinstance(camera, (int, np.integer)) and not isinstance(camera, bool) and 0 <= camera < model.ncam:
        return int(camera)
    raise ValueError(f"no camera {camera!r} in the scene; {listing}")
