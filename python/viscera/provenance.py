"""What a written file records of its making: the package versions and the time (UTC); shared
by recordings (viscera.recording) and policy files (viscera.policy_file)."""

from __future__ import annotations

import datetime

import mujoco


def versions() -> dict:
    """The viscera and mujoco versions ("source" for a checkout that is not installed)."""
    from importlib import metadata
    try:
        version = metadata.version("viscera")
    except metadata.PackageNotFoundError:
        version = "source"  # run from a checkout, not installed
    return {"viscera": version, "mujoco": mujoco.__version__}


def now() -> str:
    """The time, UTC, to the second (ISO 8601)."""
    return datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")
