"""Files written whole or not at all: written to a temporary name beside the target, then renamed,
so an interrupted write never leaves a half file under the name (recordings, policy files)."""

from __future__ import annotations

import os
import pathlib
import tempfile

import numpy as np


def save_npz(path: str | os.PathLike, compressed: bool = False, **arrays) -> None:
    """numpy's .npz of `arrays` at `path` (zip-compressed if `compressed`), renamed there once whole,
    with the permissions a plain open() would give it."""
    path = pathlib.Path(path)
    handle, temporary = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".npz", dir=path.parent)
    try:
        with os.fdopen(handle, "wb") as file:
            (np.savez_compressed if compressed else np.savez)(file, **arrays)
        mask = os.umask(0o022)
        os.umask(mask)
        os.chmod(temporary, 0o666 & ~mask)  # mkstemp's file is private
        os.replace(temporary, path)
    except BaseException:
        os.unlink(temporary)
        raise
