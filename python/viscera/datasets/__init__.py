"""Demonstrations as standard datasets: LeRobot's and Minari's, each written by its own library.

    python -m viscera dataset grasp_lift --policy scripted --seeds 0:50 --format lerobot --out data/grasp_lift
    viscera.datasets.write("grasp_lift", "data/grasp_lift", "minari", demonstrator="scripted", seeds=range(50))
    viscera.datasets.write("grasp_lift", "data/bc", "minari", demonstrator="grasp_lift_bc.npz")  # a policy file

Episodes come from a demonstrator (viscera.datasets.episodes.DEMONSTRATORS: the task's scripted
policy, uniform random actions, idle tools; or a policy file, viscera.policy_file, each worker
loading it from its path and checking it is the file checked at the start) on the given task
seeds, or from the recordings
of people (`python -m viscera record` / `teleop` files, replayed action by action, each checked to
end in the state it recorded). They run in
worker processes and are written in seed (or file) order, so the dataset does not depend on
the number of workers. The dataset is written in a hidden staging folder beside `out` and
moved to `out` once whole: an interrupted or failed collection removes it, and a process killed
outright leaves only the hidden `.NAME.partial-XXXX` folder, never a dataset at `out`. (One
exception keeps it: a whole dataset whose `out` appeared meanwhile stays in the staging folder,
which the error names.)

Each format is an optional extra (pip install "viscera[lerobot]", "viscera[minari]");
lerobot_format and minari_format describe what is written where.
"""

from __future__ import annotations

import collections
import concurrent.futures
import contextlib
import dataclasses
import importlib.util
import multiprocessing
import os
import pathlib
import shutil
import signal
import tempfile
import threading
import time

import numpy as np

from viscera.datasets import episodes

FORMATS = ("lerobot", "minari")
EXTRA_MODULES = {"lerobot": "lerobot", "minari": "minari"}


class DatasetError(ValueError):
    """A request that cannot be collected: one line naming the argument, its value and what is wrong."""

    def __init__(self, argument: str, value, problem: str):
        shown = f"{value.start}:{value.stop}" if isinstance(value, range) else repr(value)
        super().__init__(f"{argument} {shown}: {problem}")
        self.argument, self.value, self.problem, self.shown = argument, value, problem, shown

    def __reduce__(self):  # raised in a worker process, it crosses back whole
        return DatasetError, (self.argument, self.value, self.problem)


def check_format(format: str) -> None:
    """That `format` is known and its library installed (the extra)."""
    if format not in FORMATS:
        raise DatasetError("format", format, f"must be one of {', '.join(FORMATS)}")
    module = EXTRA_MODULES[format]
    if importlib.util.find_spec(module) is None or (format == "minari" and importlib.util.find_spec("h5py") is None):
        raise DatasetError("format", format, f"needs the {format} extra, not installed: "
                           f"pip install \"viscera[{format}]\"")


def check_out(out: str | os.PathLike) -> pathlib.Path:
    """`out` as a path that does not exist yet, in a writable folder."""
    path = pathlib.Path(out)
    if path.exists():
        raise DatasetError("out", str(path), "exists: a dataset is written to a new path")
    if not path.parent.is_dir():
        raise DatasetError("out", str(path), f"folder {str(path.parent)!r} does not exist")
    try:  # tried, not asked (os.access says yes to root, and to a read-only file system)
        os.rmdir(tempfile.mkdtemp(prefix=f".{path.name}.probe-", dir=path.parent))
    except OSError as error:
        raise DatasetError("out", str(path), f"folder {str(path.parent)!r} is not writable "
                           f"({error.strerror or error})") from None
    return path


@dataclasses.dataclass(frozen=True, eq=False)
class Job:
    """One episode to collect: the environment's arguments, the task's seed, who acts."""

    env_kwargs: tuple            # sorted items of episodes.env_kwargs
    seed: int
    demonstrator: str
    actions: np.ndarray | None = None   # a recording's dm_env actions
    action_noise: float = 0.0           # episodes.run's
    final_state_sha256: str | None = None  # a recording's: its replay must end there
    source: str = ""                    # a recording's file name, for errors
    policy_file: str | None = None      # a policy file's absolute path (demonstrator: its label)
    policy_sha256: str | None = None    # ... and its SHA-256 when it was checked: a worker loads the same file
    camera: np.ndarray | None = None    # a recording's steered laparoscope, a pose per tick (viscera.laparoscope)
    optics_deg: float = 0.0             # ... and its optics


def recording_jobs(task: str, folder: str | os.PathLike, pixels: bool, size, camera: str) -> list[Job]:
    """One job per recording file (*.npz, name order) of `folder`, each of `task`, all of one
    scene, control period and time limit (one dataset has one environment)."""
    from viscera import recording

    folder = pathlib.Path(folder)
    if not folder.is_dir():
        raise DatasetError("recordings", str(folder), "not a folder")
    files = sorted(folder.glob("*.npz"))
    if not files:
        raise DatasetError("recordings", str(folder), "no recording (*.npz) in it")
    jobs = []
    for path in files:
        try:
            taken = recording.load(path)
        except recording.RecordingError as error:
            raise DatasetError("recordings", str(folder), str(error)) from None
        if taken.task != task:
            raise DatasetError("recordings", str(folder), f"{path.name} is of task {taken.task!r}, not {task!r}")
        if taken.seed is None:
            raise DatasetError("recordings", str(folder), f"{path.name} has no seed: its episode cannot be replayed")
        if taken.steps == 0:
            raise DatasetError("recordings", str(folder), f"{path.name} has no action")
        kwargs = tuple(sorted(episodes.env_kwargs(task, taken.scene, pixels, size, camera, taken.control_timestep_s,
                                                  taken.time_limit_s).items()))
        if jobs and kwargs != jobs[0].env_kwargs:
            first, this = dict(jobs[0].env_kwargs), dict(kwargs)
            differ = ", ".join(f"{k} {this.get(k)!r} against {first.get(k)!r}" for k in sorted(set(first) | set(this))
                               if first.get(k) != this.get(k))
            raise DatasetError("recordings", str(folder), f"{path.name} differs from {jobs[0].source} in {differ}: "
                               "one dataset holds one environment's episodes")
        jobs.append(Job(kwargs, int(taken.seed), taken.policy, taken.actions,
                        final_state_sha256=taken.final_state_sha256, source=path.name, camera=taken.camera,
                        optics_deg=taken.optics_deg))
    return jobs


_environments: dict = {}  # this process's environments, by their arguments
_policies: dict = {}  # this process's policy files, by path and SHA-256


def check_policy_file(path, task: str, scene: str, pixels: bool, size, camera: str):
    """The policy file at `path` (viscera.policy_file), for `task` in `scene`, with the pixels it
    reads among the dataset's (`pixels` at `size` from `camera`); else a DatasetError naming it."""
    from viscera import policy_file

    try:
        learned = policy_file.load(path)
        learned.check_task(task, scene)
    except policy_file.PolicyFileError as error:
        raise DatasetError("demonstrator", str(path), error.problem) from None
    wanted = learned.pixels
    if wanted is not None and not (pixels and tuple(size) == (wanted["height"], wanted["width"])
                                   and camera == wanted["camera"]):
        raise DatasetError("demonstrator", str(path), f"reads the {wanted['camera']} camera's "
                           f"{wanted['height']}x{wanted['width']} RGB: collect with --pixels --size "
                           f"{wanted['height']}x{wanted['width']}")
    return learned


def _policy(job: Job, env):
    """The job's policy file, loaded once per process and checked to be the file checked at the
    start and to act in `env`."""
    from viscera import policy_file

    key = (job.policy_file, job.policy_sha256)
    learned = _policies.get(key)
    if learned is None:
        try:
            learned = policy_file.load(job.policy_file)
            if learned.sha256 != job.policy_sha256:
                raise DatasetError("demonstrator", job.policy_file, "changed during the collection (its SHA-256 "
                                   f"is now {learned.sha256[:12]}..., it was {job.policy_sha256[:12]}...)")
            learned.check_env(env.dm_env)
        except policy_file.PolicyFileError as error:
            raise DatasetError("demonstrator", job.policy_file, error.problem) from None
        _policies[key] = learned
    return learned


def _collect(job: Job) -> episodes.Episode:
    env = _environments.get(job.env_kwargs)
    if env is None:
        from viscera.scale.gym_env import TaskEnv

        env = _environments[job.env_kwargs] = TaskEnv(**dict(job.env_kwargs))
    policy = _policy(job, env) if job.policy_file is not None else None
    episode = episodes.run(env, job.seed, job.demonstrator, job.actions, job.action_noise, policy=policy,
                           camera=job.camera, optics_deg=job.optics_deg)
    if job.final_state_sha256 is not None:
        from viscera import recording

        if recording.final_state_sha256(env.dm_env.physics) != job.final_state_sha256:
            raise DatasetError("recordings", job.source, "its replay does not end in the recorded state (another "
                               "viscera or MuJoCo version?): its episode is not the one recorded")
    return episode


def _close_environments() -> None:
    while _environments:
        _environments.popitem()[1].close()


class _CtrlC:
    """Ctrl-C that cannot be lost: the press is remembered and `check()` raises KeyboardInterrupt
    at the next episode or wait. With `raise_now` (episodes run in this process) the handler
    raises at once too; Python drops it if it lands in a garbage collector's callback
    ("Exception ignored in ..."), which the remembered press makes up for. Without (worker
    processes), the handler only remembers: raised inside the process pool's own calls, it could
    leave their locks held. Installed only over Python's own handler, in the main thread (an
    ignored or custom SIGINT is left alone)."""

    def __init__(self, raise_now: bool):
        self.pressed, self.previous, self.raise_now = False, None, raise_now

    def __enter__(self):
        if (threading.current_thread() is threading.main_thread()
                and signal.getsignal(signal.SIGINT) is signal.default_int_handler):
            self.previous = signal.signal(signal.SIGINT, self._handler)
        return self

    def _handler(self, signum, frame):
        self.pressed = True
        if self.raise_now:
            raise KeyboardInterrupt

    def check(self) -> None:
        if self.pressed:
            raise KeyboardInterrupt

    def __exit__(self, *exc):
        if self.previous is not None:
            signal.signal(signal.SIGINT, self.previous)


def _in_order(jobs: list[Job], workers: int, ctrl_c: _CtrlC):
    """The episodes of `jobs`, in order, from `workers` processes (or this one)."""
    if workers == 1:
        for job in jobs:
            ctrl_c.check()
            yield _collect(job)
        return
    # spawn: fresh interpreters, safe beside this process's threads; results come back in job
    # order, at most 2 x workers in flight so that finished episodes (images and all) do not pile up
    pool = concurrent.futures.ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn"),
                                                  initializer=_worker_ignores_ctrl_c)
    try:
        waiting, pending = collections.deque(jobs), collections.deque()
        while waiting or pending:
            while waiting and len(pending) < 2 * workers:
                pending.append(pool.submit(_collect, waiting.popleft()))
            while True:  # waits in short slices: a Ctrl-C the collector dropped is seen within one
                ctrl_c.check()
                try:
                    episode = pending[0].result(timeout=0.25)
                    break
                except concurrent.futures.TimeoutError:
                    continue
            pending.popleft()
            yield episode
    finally:
        # stopped early (Ctrl-C, an error, the writer's) or done: the queued episodes are cancelled,
        # the running ones finish (a worker ignores Ctrl-C; one killed mid-reply would leave the
        # pool's reader waiting for the rest of its message for ever)
        pool.shutdown(wait=True, cancel_futures=True)


def _worker_ignores_ctrl_c() -> None:
    """A worker leaves Ctrl-C (sent to the whole process group) to the parent, which stops it."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def write(task: str, out: str | os.PathLike, format: str, demonstrator: str = "scripted", seeds=range(10),
          recordings: str | os.PathLike | None = None, episodes_limit: int | None = None, scene: str = "abdomen",
          pixels: bool = False, size: tuple[int, int] = (84, 84), camera: str = "laparoscope", workers: int = 1,
          progress: bool = False, action_noise: float = 0.0) -> dict:
    """Collect episodes of `task` and write them as a `format` dataset at `out` (a new path).

    demonstrator: one of episodes.DEMONSTRATORS, or a policy file's path (viscera.policy_file.is_path:
    ending in .npz or holding a path separator; the environment gets its control period; a policy
    reading pixels needs `pixels` at its size; the dataset's demonstrator is then "policy" and each
    episode's the file's label, file:NAME#SHA256-PREFIX), on the task's `seeds` (on `scene`); or
    recordings: a folder of recording files, each replayed in its own scene, control period and
    time limit (all alike) and checked to end in its recorded state (demonstrator is then
    "recordings"). episodes_limit: at most that many (the first seeds or files). action_noise:
    noise injected into the actions taken (episodes.run), the demonstrator's commands kept apart;
    not with recordings. Returns what was written, with the wall time and episodes per hour per
    worker.
    """
    import viscera.tasks

    if task not in viscera.tasks.ALL:
        raise DatasetError("task", task, f"must be one of {', '.join(viscera.tasks.ALL)}")
    learned = None  # a policy file's policy
    check_format(format)
    out = check_out(out)
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise DatasetError("workers", workers, "must be an integer, at least 1")
    if not (np.isfinite(action_noise) and 0.0 <= action_noise <= 1.0):
        raise DatasetError("action_noise", action_noise, "must be from 0 to 1 (normalised action units)")
    if episodes_limit is not None and (isinstance(episodes_limit, bool) or not isinstance(episodes_limit, int)
                                       or episodes_limit < 1):
        raise DatasetError("episodes_limit", episodes_limit, "must be an integer, at least 1")
    if recordings is not None:
        if action_noise:
            raise DatasetError("action_noise", action_noise, "not with recordings: they replay what was done")
        demonstrator = "recordings"
        jobs = recording_jobs(task, recordings, pixels, size, camera)
    else:
        from viscera.policy_file import is_path
        if demonstrator not in episodes.DEMONSTRATORS and not is_path(demonstrator):
            raise DatasetError("demonstrator", demonstrator, f"must be one of {', '.join(episodes.DEMONSTRATORS)}"
                               ", or a policy file's path")
        if demonstrator not in episodes.DEMONSTRATORS:
            learned = check_policy_file(demonstrator, task, scene, pixels, size, camera)
        from viscera.scale.worker import checked_seeds
        if episodes_limit is not None:
            seeds = seeds[:episodes_limit]  # before the seeds are listed: a range may be 2^32 long
        try:
            seeds = checked_seeds(seeds)
        except ValueError as error:
            raise DatasetError("seeds", seeds, str(error)) from None
        kwargs = tuple(sorted(episodes.env_kwargs(task, scene, pixels, size, camera, learned.control_timestep_s
                                                  if learned is not None else None).items()))
        if learned is not None:
            from viscera import policy_file
            from viscera.scale.gym_env import TaskEnv
            env = TaskEnv(**dict(kwargs))  # checked against the file before the first episode, not in a worker
            try:
                learned.check_env(env.dm_env)
            except policy_file.PolicyFileError as error:
                raise DatasetError("demonstrator", str(demonstrator), error.problem) from None
            finally:
                env.close()
            path, demonstrator = str(pathlib.Path(learned.path).resolve()), "policy"
            jobs = [Job(kwargs, int(seed), learned.label, None, float(action_noise), policy_file=path,
                        policy_sha256=learned.sha256) for seed in seeds]
        else:
            jobs = [Job(kwargs, int(seed), demonstrator, None, float(action_noise)) for seed in seeds]
    jobs = jobs[:episodes_limit]
    if not jobs:
        raise DatasetError("seeds", seeds, "no episode to collect")

    spec = episodes.env_spec(dict(jobs[0].env_kwargs))
    writer_class = _writer(format)
    # a fresh hidden folder beside `out` (a killed run's stays apart); the dataset is written in it
    # and moved to `out` once whole
    staging = pathlib.Path(tempfile.mkdtemp(prefix=f".{out.name}.partial-", dir=out.parent))
    start = time.perf_counter()
    written = {"episodes": 0, "frames": 0, "successes": 0}
    workers = min(workers, len(jobs))
    bar = None
    if progress:
        from tqdm import tqdm
        bar = tqdm(total=len(jobs), unit="episode", desc=f"{task} {demonstrator} -> {format}")
    writer, env, finished = None, None, False
    try:
        from viscera.scale.gym_env import TaskEnv
        env = TaskEnv(**dict(jobs[0].env_kwargs))  # the spaces the writers describe
        writer = writer_class(staging / "dataset", env, spec, task, demonstrator,
                              description=f"viscera {task}: {learned.label if learned else demonstrator} demonstrations")
        with _CtrlC(raise_now=workers == 1) as ctrl_c, contextlib.closing(_in_order(jobs, workers, ctrl_c)) as collected:
            for episode in collected:
                ctrl_c.check()
                writer.add(episode)
                written["episodes"] += 1
                written["frames"] += episode.steps
                written["successes"] += int(episode.success)
                if bar is not None:
                    bar.update()
        writer.finish()
        finished = True
        if out.exists():
            raise DatasetError("out", str(out), f"appeared during the collection; the dataset is kept in "
                               f"{str(staging / 'dataset')!r}")
        os.rename(staging / "dataset", out)  # whole, under its name
        staging.rmdir()
    except BaseException as error:
        keep = finished and isinstance(error, DatasetError)
        try:
            if writer is not None and not finished:
                writer.abort()
        finally:
            if not keep:
                shutil.rmtree(staging, ignore_errors=True)
        raise
    finally:
        if bar is not None:
            bar.close()
        if env is not None:
            env.close()
        _close_environments()
    wall_s = time.perf_counter() - start
    if learned is not None:
        written["policy"] = learned.label
    return dict(written, task=task, format=format, demonstrator=demonstrator, out=str(out), pixels=bool(pixels),
                workers=workers, wall_s=wall_s,
                episodes_per_hour_per_worker=written["episodes"] / (wall_s / 3600.0) / workers)


def _writer(format: str):
    if format == "lerobot":
        from viscera.datasets.lerobot_format import LeRobotWriter
        return LeRobotWriter
    from viscera.datasets.minari_format import MinariWriter
    return MinariWriter


def load(out: str | os.PathLike, format: str, task: str, demonstrator: str):
    """The dataset at `out`, by its own library's loader."""
    if format == "lerobot":
        from viscera.datasets import lerobot_format
        return lerobot_format.load(out, task, demonstrator)
    from viscera.datasets import minari_format
    return minari_format.load(out, task, demonstrator)
