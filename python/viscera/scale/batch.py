"""Batched stepping of one scene: N initial states and N control sequences in, states and sensor data out.

    stepper = viscera.scale.batch.BatchStepper(model, threads=2)   # one shared MjModel, one MjData per thread
    result = stepper.step(initial_state, control)             # (N, nstate), (N, T, nu)
    result.state        # (N, T, nstate): the FULLPHYSICS state after each step
    result.sensordata   # (N, T, nsensordata): the sensors computed in each step

A thin layer over ``mujoco.rollout``: its thread pool is kept between calls (a
persistent ``mujoco.rollout.Rollout``), the GIL is released for the whole batch,
and inputs are checked before any reaches MuJoCo (shapes, finiteness), with an
error that names the argument and the first bad entry. The plugin keeps its
state in ``plugin_state`` (part of FULLPHYSICS) and no mutable globals, so the
result is bit-identical to stepping each entry alone (``serial_step``, the
reference used by the tests and the benchmark's peer).

States are ``mjSTATE_FULLPHYSICS`` vectors (time, qpos, qvel, act, mocap, plugin
state; ``state_of`` reads one). Controls are ``data.ctrl`` values, one row per
physics step (model.opt.timestep s). ``initial_warmstart`` (N, nv) is the
constraint solver's warm start (``data.qacc_warmstart``, m/s^2 or rad/s^2); to
continue a running simulation bit for bit pass the data's own, otherwise it is zero.
"""

from __future__ import annotations

import dataclasses
import os

import mujoco
import numpy as np
from mujoco import rollout

from viscera.checks import finite_array

FULLPHYSICS = mujoco.mjtState.mjSTATE_FULLPHYSICS


def available_cores() -> int:
    """The cores this process may run on (the affinity mask, not the machine's count)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


def state_of(model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
    """The FULLPHYSICS state vector of `data`."""
    state = np.empty(mujoco.mj_stateSize(model, FULLPHYSICS))
    mujoco.mj_getState(model, data, state, FULLPHYSICS)
    return state


@dataclasses.dataclass(frozen=True)
class BatchResult:
    state: np.ndarray        # (N, T, nstate) FULLPHYSICS after each step
    sensordata: np.ndarray   # (N, T, nsensordata) as computed during each step


def _check_inputs(model, initial_state, control, initial_warmstart):
    nstate = mujoco.mj_stateSize(model, FULLPHYSICS)
    initial_state = finite_array("initial_state", initial_state, (None, nstate))
    batch = initial_state.shape[0]
    control = finite_array("control", control, (batch, None, model.nu))
    if control.shape[1] == 0:
        raise ValueError("control has no steps (shape[1] = 0)")
    if initial_warmstart is None:
        initial_warmstart = np.zeros((batch, model.nv))
    initial_warmstart = finite_array("initial_warmstart", initial_warmstart, (batch, model.nv))
    return initial_state, control, initial_warmstart


class BatchStepper:
    """Steps batches of one model on `threads` threads, each with its own MjData (see the module doc)."""

    def __init__(self, model: mujoco.MjModel, threads: int | None = None):
        threads = available_cores() if threads is None else int(threads)
        if threads < 1:
            raise ValueError(f"threads = {threads}: must be at least 1")
        self.model = model
        self.threads = threads
        self._datas = [mujoco.MjData(model) for _ in range(threads)]
        # nthread 0 runs on the calling thread (still without the GIL)
        self._pool = rollout.Rollout(nthread=threads if threads > 1 else 0)

    @property
    def state_size(self) -> int:
        return mujoco.mj_stateSize(self.model, FULLPHYSICS)

    def step(self, initial_state, control, initial_warmstart=None, chunk_size: int | None = None) -> BatchResult:
        """Step each of the N entries len(control[n]) times from its initial state (see the module doc).

        chunk_size: entries a thread takes at once (mujoco.rollout's default if None); the
        result does not depend on it, nor on the thread count.
        """
        if self._pool is None:
            raise RuntimeError("BatchStepper is closed")
        if chunk_size is not None and (not isinstance(chunk_size, (int, np.integer)) or chunk_size < 1):
            raise ValueError(f"chunk_size = {chunk_size!r}: must be None or an integer of at least 1")
        initial_state, control, initial_warmstart = _check_inputs(
            self.model, initial_state, control, initial_warmstart)
        state, sensordata = self._pool.rollout(
            self.model, self._datas, initial_state, control, initial_warmstart=initial_warmstart,
            chunk_size=chunk_size)
        return BatchResult(state=state, sensordata=sensordata)

    def close(self) -> None:
        """Stop the thread pool (also done when the stepper is garbage collected)."""
        if self._pool is not None:
            self._pool.close()
            self._pool = None

    def __enter__(self) -> "BatchStepper":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def serial_step(model, initial_state, control, initial_warmstart=None) -> BatchResult:
    """The same result as BatchStepper.step, by mj_step from Python (the reference).

    model: one MjModel, or one per batch entry (as mujoco.rollout takes them; same sizes).
    """
    models = list(model) if isinstance(model, (list, tuple)) else None
    first = models[0] if models else model
    initial_state, control, initial_warmstart = _check_inputs(first, initial_state, control, initial_warmstart)
    batch, steps = control.shape[:2]
    if models is not None and len(models) != batch:
        raise ValueError(f"model holds {len(models)} models for {batch} batch entries")
    state = np.empty((batch, steps, initial_state.shape[1]))
    sensordata = np.empty((batch, steps, first.nsensordata))
    datas = {}
    for n in range(batch):
        entry_model = models[n] if models else model
        data = datas.setdefault(id(entry_model), mujoco.MjData(entry_model))
        mujoco.mj_resetData(entry_model, data)
        mujoco.mj_setState(entry_model, data, initial_state[n], FULLPHYSICS)
        data.qacc_warmstart[:] = initial_warmstart[n]
        for t in range(steps):
            data.ctrl[:] = control[n, t]
            mujoco.mj_step(entry_model, data)
            mujoco.mj_getState(entry_model, data, state[n, t], FULLPHYSICS)
            sensordata[n, t] = data.sensordata
    return BatchResult(state=state, sensordata=sensordata)
