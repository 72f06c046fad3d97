"""The gymnasium adapter keeps dm_env's semantics exactly; every vector backend steps identically."""

import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import viscera
import viscera.tasks
from viscera.scale import gym_env as gymnasium_env, vector

SHORT = {"time_limit": 0.1}  # 5 control steps: autoreset happens inside the tests


def test_passes_gymnasium_checks_and_is_registered():
    env = gymnasium_env.TaskEnv("clear_area", seed=0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # advice (unbounded observations, unnormalised actions), not errors
        check_env(env, skip_render_check=True)
    made = gym.make("viscera/ClearArea-v0")
    assert made.observation_space == env.observation_space and made.action_space == env.action_space
    # actions normalised to [-1, 1]: the ends are the actuators' control ranges
    assert np.all(env.action_space.low == -1.0) and np.all(env.action_space.high == 1.0)
    spec = env.dm_env.action_spec()
    np.testing.assert_array_equal(env.dm_action(env.action_space.low), spec.minimum)
    np.testing.assert_array_equal(env.dm_action(env.action_space.high), spec.maximum)
    np.testing.assert_allclose(env.gym_action(env.dm_action(np.full(9, 0.25))), 0.25)
    coverage = env.observation_layout["target_coverage"][0]
    assert np.all(env.observation_space.low[coverage] == 0.0) and np.all(env.observation_space.high[coverage] == 1.0)


@pytest.mark.parametrize("task", viscera.tasks.ALL)
def test_every_task_has_a_gymnasium_id_and_passes_the_checker_quietly(task):
    """Every task: its id makes it, the checker passes without warnings about the actions."""
    import viscera.gymnasium_ids
    env = gym.make(viscera.gymnasium_ids.ENV_IDS[task])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env.unwrapped, skip_render_check=True)
    assert not [w for w in caught if "action" in str(w.message).lower()], [str(w.message) for w in caught]


def test_observations_and_rewards_are_the_dm_env_ones_bit_for_bit():
    env = gymnasium_env.TaskEnv("clear_area", seed=3, flatten=True)
    reference = viscera.tasks.load("clear_area", seed=3)
    observation, info = env.reset(seed=3)
    time_step = reference.reset()
    assert info == {"step_type": 0, "is_success": False}  # dm_env's FIRST discount is None: left out
    rng = np.random.default_rng(0)
    for _ in range(4):
        parts = env.unflatten(observation)
        for key, value in time_step.observation.items():
            assert np.array_equal(parts[key], value), key
        action = rng.uniform(env.action_space.low, env.action_space.high)
        observation, reward, terminated, truncated, info = env.step(action)
        time_step = reference.step(env.dm_action(action))
        assert reward == time_step.reward and not (terminated or truncated)
        assert info == {"step_type": 1, "discount": 1.0, "is_success": False, "cost": info["tissue_cost"],
                        "tissue_cost": info["tissue_cost"]}
    nested = gymnasium_env.TaskEnv("clear_area", seed=3, flatten=False)
    assert list(nested.observation_space.spaces) == list(reference.observation_spec())


def test_is_success_reports_the_tasks_lasting_success():
    """info["is_success"] (what stable-baselines3 reads at an episode's end) is the task's own
    success: False until the scripted grasp has held the band up for its second, True on the
    step that terminates the episode."""
    import dm_env
    env = gymnasium_env.TaskEnv("grasp_lift", seed=1000)
    policy = viscera.tasks.scripted_policy(env.dm_env)
    observation, info = env.reset(seed=1000)
    reward, seen, terminated, truncated = None, [], False, False
    while not (terminated or truncated):
        seen.append(info["is_success"])
        step = dm_env.TimeStep(dm_env.StepType(info["step_type"]), reward, info.get("discount"),
                               env.unflatten(observation))  # the time step the script reads
        observation, reward, terminated, truncated, info = env.step(env.gym_action(policy(step)))
    assert terminated and info["is_success"] and not any(seen)
    assert env.dm_env.task.success(env.dm_env.physics)


def test_render_draws_through_the_pixel_camera_at_the_size_asked():
    """render() is the pixel camera's RGB (viscera.pixels.Camera, one draw) from render_camera at
    render_size: the same pixels as the camera's own frame, the bowel in view; a bad size is refused
    by name."""
    from viscera.pixels import Camera
    env = gymnasium_env.TaskEnv("clear_area", seed=0, render_mode="rgb_array", render_size=(120, 160))
    env.reset(seed=0)
    env.step(env.action_space.low)
    frame = env.render()
    assert frame.shape == (120, 160, 3) and frame.dtype == np.uint8
    reference = Camera(160, 120, "top").render(env.dm_env.physics)
    assert np.array_equal(frame, reference["pixels"])
    red, green = frame[..., 0].astype(int), frame[..., 1].astype(int)
    assert ((red > 200) & (red > green + 20)).mean() > 0.15  # the bowel's pink: a fifth of the frame
    assert gymnasium_env.TaskEnv("clear_area", seed=0).render() is None  # no render_mode: nothing drawn
    env.close()
    with pytest.raises(ValueError, match=r"render_size = \(0, 10\): must be \(height, width\)"):
        gymnasium_env.TaskEnv("clear_area", seed=0, render_mode="rgb_array", render_size=(0, 10))


def test_time_limit_truncates_and_the_task_terminates(monkeypatch):
    env = gymnasium_env.TaskEnv("clear_area", seed=0, **SHORT)
    env.reset()
    flags = [env.step(env.action_space.low)[2:4] for _ in range(5)]
    assert flags == [(False, False)] * 4 + [(False, True)]  # dm_env: LAST with discount 1
    with pytest.raises(RuntimeError, match="call reset"):
        env.step(env.action_space.low)
    env.reset()
    # the task ends the episode (dm_env: LAST with discount 0): terminated, not truncated
    monkeypatch.setattr(env.dm_env.task, "get_termination", lambda physics: 0.0)
    _, _, terminated, truncated, info = env.step(env.action_space.low)
    assert (terminated, truncated, info["discount"]) == (True, False, 0.0)


def test_refuses_non_finite_and_wrong_sized_actions_by_name():
    env = gymnasium_env.TaskEnv("clear_area", seed=0)
    env.reset()
    action = env.action_space.low.copy()
    action[4] = np.nan
    with pytest.raises(ValueError, match=r"action\[4\] = nan: must be finite"):
        env.step(action)
    with pytest.raises(ValueError, match=r"action has shape \(8,\), expected \(9\)"):
        env.step(action[:8])
    envs = vector.make("clear_area", num_envs=2, seed=None, backend="threads")  # seed None: unseeded
    envs.reset()
    with pytest.raises(ValueError, match="actions hold 1 actions for 2 environments"):
        envs.step(np.zeros((1, 9)))
    envs.close()


def run(envs, steps=12, seed=7):
    """Observations, rewards, flags and info over `steps` random steps, autoreset included."""
    rng = np.random.default_rng(seed)
    space = envs.single_action_space
    record = list(envs.reset(seed=seed))
    for _ in range(steps):
        record += envs.step(rng.uniform(space.low, space.high, (envs.num_envs,) + space.shape))
    envs.close()
    return record


def assert_same(record, reference):
    assert len(record) == len(reference)
    for got, want in zip(record, reference):
        if isinstance(want, dict):  # infos: the same keys and values, batched by gymnasium
            assert got.keys() == want.keys()
            for key in want:
                assert np.asarray(got[key]).tolist() == np.asarray(want[key]).tolist(), key
        else:
            assert np.array_equal(got, want)


@pytest.fixture(scope="module")
def serial_record():
    return run(vector.make("clear_area", num_envs=3, seed=7, backend="serial", **SHORT))


@pytest.mark.parametrize("backend, workers", [("threads", 2), ("threads", 3), ("processes", None)])
def test_backends_equal_the_serial_vector_env(serial_record, backend, workers):
    envs = vector.make("clear_area", num_envs=3, seed=7, backend=backend, workers=workers, **SHORT)
    record = run(envs)
    assert_same(record, serial_record)
    truncations = np.array([r for r in record[2:] if isinstance(r, np.ndarray) and r.dtype == bool])
    assert truncations.any()  # the run crossed an autoreset


def test_gymnasium_make_vec_gives_every_mode(serial_record):
    """gym.make_vec on the registered id: sync, async (spawned) and our threads entry point step alike."""
    records = []
    for mode, options in (("sync", {}), ("async", {"vector_kwargs": {"context": "spawn"}}),
                          ("vector_entry_point", {})):
        envs = gym.make_vec("viscera/ClearArea-v0", num_envs=3, vectorization_mode=mode, **SHORT, **options)
        assert isinstance(envs, (gym.vector.SyncVectorEnv, gym.vector.AsyncVectorEnv, vector.ThreadVectorEnv))
        records.append(run(envs))
    threaded = gym.make_vec("viscera/ClearArea-v0", num_envs=1, vectorization_mode="vector_entry_point")
    assert isinstance(threaded, vector.ThreadVectorEnv)
    threaded.close()
    for record in records:
        assert_same(record, serial_record)


def test_same_step_autoreset_matches_gymnasium():
    fns = [lambda i=i: gymnasium_env.TaskEnv("clear_area", seed=i, **SHORT) for i in range(2)]
    reference = run(gym.vector.SyncVectorEnv(fns, autoreset_mode="SameStep"), steps=5)  # the 5th step ends
    record = run(vector.ThreadVectorEnv(fns, workers=2, autoreset_mode="SameStep"), steps=5)
    assert "final_obs" in reference[-1]
    assert_same([r for r in record if not isinstance(r, dict)], [r for r in reference if not isinstance(r, dict)])
    assert np.array_equal(np.stack(record[-1]["final_obs"]), np.stack(reference[-1]["final_obs"]))


def test_cleanrl_style_loop_records_episode_returns():
    """The loop of CleanRL's ppo_continuous_action: vector env, RecordEpisodeStatistics, next-step autoreset."""
    envs = gym.wrappers.vector.RecordEpisodeStatistics(
        vector.make("clear_area", num_envs=2, seed=1, backend="threads", **SHORT))
    spec = viscera.tasks.load("clear_area").observation_spec()  # the flat observation: every entry of the spec
    assert envs.single_observation_space.shape == (sum(int(np.prod(e.shape)) for e in spec.values()),)
    assert envs.single_action_space.shape == (9,)
    observation, _ = envs.reset(seed=1)
    returns = np.zeros(2)
    episodes = []
    for _ in range(5):
        action = np.clip(np.zeros((2, 9)), envs.single_action_space.low, envs.single_action_space.high)
        observation, reward, terminated, truncated, info = envs.step(action)
        returns += reward
        if "episode" in info:
            episodes.append(info["episode"]["r"][info["_episode"]])
    envs.close()
    assert len(episodes) == 1 and np.allclose(episodes[0], returns)


@pytest.mark.parametrize("kwargs, message", [
    ({"backend": "gpu"}, r"backend = 'gpu': must be one of \('serial', 'threads', 'processes'\)"),
    ({"num_envs": 0}, r"num_envs = 0: must be at least 1"),
    ({"backend": "processes", "workers": 2}, r"workers = 2: only the 'threads' backend takes it"),
    ({"workers": 0}, r"workers = 0: must be at least 1"),
    ({"num_envs": 2.5}, r"num_envs = 2.5: must be an integer"),
    ({"seed": -1}, r"seed = -1: must be at least 0"),
])
def test_refuses_bad_arguments_by_name(kwargs, message):
    with pytest.raises(ValueError, match=message):
        vector.make("clear_area", **({"num_envs": 1} | kwargs))
