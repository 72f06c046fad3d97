"""viscera.scale.collect: every backend returns the serial trajectories, bit for bit, in seed order."""

import subprocess
import sys
import textwrap

import numpy as np
import pytest

import viscera.tasks
from viscera import scale

SEEDS = [5, 2, 9]  # not sorted: the order given is the order returned
STEPS = 12
SHORT = {"time_limit": 0.2}  # 10 control steps of 0.02 s: episodes end inside some collections


@pytest.fixture(scope="module")
def serial():
    return scale.collect("clear_area", SEEDS, STEPS, workers=1, backend="serial")


@pytest.fixture(scope="module")
def local_ray():
    import ray  # the test extra installs it; only these tests need it
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    yield ray
    ray.shutdown()


def observation_size(**task_kwargs) -> int:
    """clear_area's flat observation length: every entry of its observation spec (440 by default:
    the tools' joints and last commands, 9 + 9, forces 12, the hold 1, the axis 300, gravity 3, the
    target 5 and its coverage 100, the held abscissa 1)."""
    spec = viscera.tasks.load("clear_area", **task_kwargs).observation_spec()
    return sum(int(np.prod(entry.shape)) for entry in spec.values())


def assert_same(trajectories, reference):
    assert [t.seed for t in trajectories] == SEEDS
    for got, want in zip(trajectories, reference):
        assert got.same_as(want), got.seed


def test_serial_trajectories_are_episodes_of_their_seeds(serial):
    assert [t.seed for t in serial] == SEEDS
    first = serial[0]
    observations, actions, rewards = first  # unpacks as the triple
    assert observations.shape == (STEPS + 1, observation_size()) and actions.shape == (STEPS, 9)
    assert rewards.shape == (STEPS,)
    assert np.all(first.discounts == 1.0) and not first.ended
    # each seed draws its own episode (bowel, tissue, tilt, target), and its policy differs
    assert not any(np.array_equal(t.observations[0], first.observations[0]) for t in serial[1:])
    assert not np.array_equal(serial[0].actions, serial[1].actions)
    assert not np.array_equal(serial[0].observations[-1], serial[1].observations[-1])
    # the observation entries are where the layout says: tool joints moved toward the commanded actions
    joints = first.observation("tool_joints")
    assert joints.shape == (STEPS + 1, 9)
    assert np.abs(joints[-1] - joints[0]).max() > 1e-3
    low, high = viscera.tasks.load("clear_area").task.contract.step_bounds()  # no step of these succeeds
    assert np.all((rewards >= low) & (rewards <= high))


@pytest.mark.parametrize("backend, workers", [("threads", 2), ("threads", 3), ("processes", 2)])
def test_local_backends_equal_serial(serial, backend, workers):
    assert_same(scale.collect("clear_area", SEEDS, STEPS, workers=workers, backend=backend), serial)


def test_two_ray_actors_equal_serial(serial, local_ray):
    assert_same(scale.collect("clear_area", SEEDS, STEPS, workers=2, backend="ray"), serial)


@pytest.mark.parametrize("backend", ["threads", "processes", "ray"])
def test_batches_as_completed_are_the_serial_trajectories(serial, local_ray, backend):
    """Each worker's batch arrives whole, in its seeds' order; together they are collect()'s trajectories."""
    with scale.make_collector(backend, "clear_area", workers=2) as collector:
        batches = list(collector.collect_as_completed(SEEDS, STEPS))
        assert sorted([t.seed for t in batch] for batch in batches) == sorted(scale.split_seeds(SEEDS, 2))
        by_seed = {t.seed: t for batch in batches for t in batch}
        assert_same([by_seed[seed] for seed in SEEDS], serial)
        early = collector.collect_as_completed(SEEDS, STEPS)
        next(early)
        with pytest.raises(RuntimeError, match="the collector is busy"):  # one worker is still stepping
            collector.collect(SEEDS, STEPS)
        early.close()  # waits for the other batch: the workers are free again
        collector.collect_as_completed(SEEDS, STEPS)  # dropped unread: waits, then frees the collector
        assert_same(collector.collect(SEEDS, STEPS), serial)
    with pytest.raises(RuntimeError, match=f"this {backend} collector is closed"):
        collector.collect(SEEDS, STEPS)


def nan_for_seed_5(env, seed):
    """A policy that breaks on one seed only."""
    return (lambda time_step: np.full(9, np.nan)) if seed == 5 else scale.RandomPolicy(env, seed)


def test_a_failed_batch_leaves_the_collector_ready(serial):
    with scale.make_collector("threads", "clear_area", workers=2, policy=nan_for_seed_5) as collector:
        with pytest.raises(ValueError, match="for seed 5 at step 0"):
            collector.collect(SEEDS, STEPS)
        with pytest.raises(ValueError, match="for seed 5 at step 0"):
            list(collector.collect_as_completed(SEEDS, STEPS))
        rest = collector.collect(SEEDS[1:], STEPS)  # the other worker finished, nothing is busy
    assert len(rest) == 2 and all(a.same_as(b) for a, b in zip(rest, serial[1:]))


def test_a_killed_ray_actor_is_restarted_and_its_batch_redone(serial, local_ray):
    ray = local_ray
    with scale.make_collector("ray", "clear_area", workers=2) as collector:
        actor = collector._actors[1]
        pending = actor.run.remote(SEEDS[1:], STEPS)  # a batch submitted (queued or running)
        ray.kill(actor, no_restart=False)  # as if its process had died
        redone = ray.get(pending)  # retried on the restarted actor
        assert len(redone) == 2 and all(a.same_as(b) for a, b in zip(redone, serial[1:]))
        assert_same(collector.collect(SEEDS, STEPS), serial)


def test_ray_stops_waiting_for_actors_that_find_no_cpus(local_ray):
    """Three 1-CPU actors on a 2-CPU Ray: one can never start; the collector says so instead of hanging."""
    with pytest.raises(TimeoutError, match=r"workers = 3: [1-3] of 3 Ray actors did not start within "
                                           r"start_timeout = 3 s; .* the cluster has 2 CPUs"):
        scale.make_collector("ray", "clear_area", workers=3, start_timeout=3.0)
    with pytest.raises(ValueError, match=r"max_restarts = -1: must be at least 0"):
        scale.make_collector("ray", "clear_area", workers=1, max_restarts=-1)


def test_a_policy_nan_is_refused_by_name_before_mujoco():
    def broken(env, seed):
        return lambda time_step: np.full(9, np.nan)
    with pytest.raises(ValueError, match=r"action of the policy for seed 5 at step 0\[0\] = nan: must be finite"):
        scale.collect("clear_area", [5], 3, backend="serial", policy=broken)


def test_a_collector_reuses_its_workers_and_episodes_end_at_the_time_limit():
    """A second collection on the same workers (envs reset, reseeded) equals a fresh one; short episodes stop."""
    with scale.make_collector("threads", "clear_area", workers=2, task_kwargs=SHORT) as collector:
        collector.collect([0, 1, 2, 3], 4)
        again = collector.collect(SEEDS, STEPS)
    fresh = scale.collect("clear_area", SEEDS, STEPS, workers=1, backend="serial", **SHORT)
    assert_same(again, fresh)
    for trajectory in again:
        assert trajectory.ended and trajectory.steps == 10  # 0.2 s / 0.02 s, then no more actions
        assert trajectory.observations.shape[0] == 11 and trajectory.discounts[-1] == 1.0  # time limit, not task


def test_a_reduced_observation_ships_a_third_of_the_bytes():
    """50 axis points in float32 (the 1,000-core plan's first step): the same episode, cast, at a third of the bytes."""
    full = scale.collect("clear_area", SEEDS, STEPS, backend="serial", axis_samples=50)
    reduced = scale.collect("clear_area", SEEDS, STEPS, workers=2, backend="processes", observation_dtype="float32",
                            axis_samples=50)
    size, default_size = observation_size(axis_samples=50), observation_size()
    assert default_size - size == 150  # 50 axis points fewer, 3 coordinates each; every other entry kept
    for small, large in zip(reduced, full):
        assert small.observations.dtype == np.float32 and small.observations.shape == (STEPS + 1, size)
        assert small.observation("intestine_axis").shape == (STEPS + 1, 150)
        assert np.array_equal(small.observations, large.observations.astype(np.float32))
        assert np.array_equal(small.actions, large.actions)  # the same seeds' policies, the same episodes
    default = scale.collect("clear_area", SEEDS[:1], STEPS, backend="serial")[0]
    per_step_records = STEPS * (9 + 1 + 1) * 8  # actions, rewards, discounts: float64
    assert reduced[0].nbytes == (STEPS + 1) * size * 4 + per_step_records
    assert default.nbytes == (STEPS + 1) * default_size * 8 + per_step_records
    # 290 float32 against 440 float64: 2.9x fewer bytes (the axis is 300 of the 440 by default)
    assert reduced[0].nbytes / default.nbytes < 0.35
    assert default.observation("intestine_axis").shape == (STEPS + 1, 300)


def test_the_scripted_gesture_collects_the_same_everywhere():
    serial = scale.collect("clear_area", [0, 1], 6, backend="serial", policy="gesture")
    threaded = scale.collect("clear_area", [0, 1], 6, workers=2, backend="threads", policy="gesture")
    assert all(a.same_as(b) for a, b in zip(serial, threaded))


@pytest.mark.parametrize("kwargs, message", [
    ({"backend": "gpu"}, r"backend = 'gpu': must be one of \('serial', 'threads', 'processes', 'ray'\)"),
    ({"workers": 0}, r"workers = 0: must be at least 1"),
    ({"task": "appendectomy"}, r"task = 'appendectomy': must be one of \('clear_area', 'grasp_lift', 'retract_reach', 'run_the_bowel'\)"),
    ({"policy": "greedy"}, r"policy = 'greedy': must be one of \('random', 'scripted', 'gesture'\)"),
    ({"seeds": [1, 2, 1]}, r"seeds repeat: \[1\]"),
    ({"steps": -1}, r"steps = -1: must be at least 0"),
    ({"steps": float("nan")}, r"steps = nan: must be an integer"),
    ({"seeds": [0, 0.7]}, r"seeds\[1\] = 0.7: must be an integer in \[0, 2\*\*32\)"),
    ({"seeds": [-3]}, r"seeds\[0\] = -3: must be an integer"),
    ({"workers": "two"}, r"workers = 'two': must be an integer"),
    ({"axis_samples": 1}, r"axis_samples = 1: must be at least 2"),
    ({"axis_samples": 100_001}, r"axis_samples = 100001: must be at most 100000"),
    ({"axis_samples": 50.0}, r"axis_samples = 50.0: must be an integer"),
    ({"observation_dtype": "float16"}, r"observation_dtype = 'float16': must be one of \('float64', 'float32'\)"),
])
def test_refuses_bad_arguments_by_name(kwargs, message):
    arguments = {"task": "clear_area", "seeds": [0], "steps": 1, "workers": 1, "backend": "threads"} | kwargs
    with pytest.raises(ValueError, match=message):
        scale.collect(**arguments)


def test_the_core_package_does_not_need_ray():
    """With Ray unimportable, collect works on the local backends and the ray backend says what to install."""
    script = textwrap.dedent("""
        import sys
        sys.modules["ray"] = None  # as if Ray were not installed
        from viscera import scale
        assert len(scale.collect("clear_area", [0, 1], 2, workers=2, backend="threads")) == 2
        try:
            scale.collect("clear_area", [0], 1, backend="ray")
        except ImportError as error:
            print(error)
    """)
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert 'pip install "viscera[ray]"' in result.stdout


@pytest.mark.parametrize("task", viscera.tasks.ALL)
def test_every_task_collects_the_same_on_threads(task):
    """viscera.scale.collect works with any task name, its scripted policy included."""
    serial = scale.collect(task, [0, 1], 5, backend="serial", policy="scripted")
    threaded = scale.collect(task, [0, 1], 5, workers=2, backend="threads", policy="scripted")
    for a, b in zip(serial, threaded):
        for x, y in zip(a, b):
            np.testing.assert_array_equal(x, y)
