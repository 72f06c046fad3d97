"""dm_control tasks, in the manner of dm_control's suite_test: specs, determinism, robustness."""

import collections
import os
import pathlib
import shutil
import subprocess
import sys

import mujoco
import numpy as np
import pytest
from mujoco import rollout

import viscera.tasks
from viscera import task_registry
from viscera.tasks import base
from viscera.tasks.gesture import ClearingGesture

ROOT = pathlib.Path(__file__).resolve().parents[2]


def random_actions(env, seed, count):
    spec = env.action_spec()
    rng = np.random.RandomState(seed)
    return [rng.uniform(spec.minimum, spec.maximum) for _ in range(count)]


def test_registry():
    """At least the four tasks the suite promises, each registered by its own module's decorator
    (the class in SUITE, its module and gymnasium id as task_registry reads them from the source),
    each with its criterion and scripted policy, and no gymnasium id twice."""
    assert viscera.tasks.ALL == tuple(task_registry.TASKS)
    assert {"clear_area", "grasp_lift", "run_the_bowel", "retract_reach"} <= set(viscera.tasks.ALL)
    for name, (module, env_id) in task_registry.TASKS.items():
        task = base.SUITE[name]
        assert task.__module__ == f"viscera.tasks.{module}" and (task.NAME, task.ENV_ID) == (name, env_id)
        assert task.CRITERION != base.BowelTask.CRITERION and task.POLICY is not None
    assert sorted(name for name, task in base.SUITE.items() if task.__module__.startswith("viscera.tasks.")) == \
        sorted(viscera.tasks.ALL)
    assert len({env_id for _, env_id in task_registry.TASKS.values()}) == len(viscera.tasks.ALL)
    with pytest.raises(KeyError, match="clear_area"):
        viscera.tasks.load("clear_the_area")


def test_the_registry_reads_the_decorators_from_the_source():
    """task_registry finds `@register("name", "id")` and `@base.register(...)` on classes, with
    string literals only (what viscera.tasks then checks it found); a name registered twice is refused."""
    source = """
@base.register("one", "viscera/One-v0")
class One(base.BowelTask): ...
@register("two", "viscera/Two-v0")
class Two(base.BowelTask): ...
@base.register(NAME, "viscera/Three-v0")
class Three(base.BowelTask): ...
@other("four", "viscera/Four-v0")
class Four: ...
"""
    assert task_registry.registrations(source) == [("one", "viscera/One-v0"), ("two", "viscera/Two-v0")]
    with pytest.raises(ValueError, match="'clear_area' is registered twice"):
        base.register("clear_area", "viscera/ClearArea-v1")(type("Other", (base.BowelTask,), {}))
    assert base.SUITE["clear_area"] is viscera.tasks.clear_area.ClearArea


TINY_TASK = '''"""tiny_reach: a task written for a test, in one file and nowhere else."""

import numpy as np

from viscera.tasks import base
from viscera.tasks.scene import Tool


@base.register("tiny_reach", "viscera/TinyReach-v0")
class TinyReach(base.BowelTask):
    """Touch the target's centre with the grasper."""

    CRITERION = "the grasper at the target's centre"
    TOOLS = (Tool("grasper", "grasper", "right"),)
    TIME_LIMIT_S = 0.1

    def condition(self, physics):
        return bool(np.linalg.norm(physics.working_point("grasper") - physics.target()[:3]) < 0.01)

    def task_observations(self, physics):
        return {"target_coverage": self.measurements(physics).coverage.copy()}

    def get_reward(self, physics):
        return self.measurements(physics).uncovered_fraction
'''


def test_a_new_task_is_one_file(tmp_path):
    """A copy of the package with one more file in viscera/tasks/ and no other change: the task is
    in ALL and the command line's choices, loads and plays, and its gymnasium id is registered
    when gymnasium is imported, still without importing dm_control."""
    package = pathlib.Path(viscera.__file__).parent
    copy = tmp_path / "viscera"
    shutil.copytree(package, copy, ignore=shutil.ignore_patterns("__pycache__"))
    if not (copy / "assets").exists():  # the source tree: its scenes live beside the package
        shutil.copytree(ROOT / "assets" / "scenes", copy / "assets")
    (copy / "tasks" / "tiny_reach.py").write_text(TINY_TASK)
    code = """
import sys, numpy as np, viscera, gymnasium as gym
print(viscera.__file__.startswith(sys.argv[1]), "dm_control" in sys.modules)
print(gym.spec("viscera/TinyReach-v0").kwargs["task"], "dm_control" in sys.modules)
from viscera.__main__ import build_parser
print(build_parser().parse_args(["play", "tiny_reach"]).task)
import viscera.tasks
print("tiny_reach" in viscera.tasks.ALL, viscera.tasks.base.SUITE["tiny_reach"].__name__)
env = viscera.tasks.load("tiny_reach", seed=0)
step, steps = env.reset(), 0
while not step.last():
    step, steps = env.step(np.zeros(env.action_spec().shape)), steps + 1
print(list(step.observation)[-1], 0.0 <= step.reward <= 1.0, steps)
genv = gym.make("viscera/TinyReach-v0")
observation, info = genv.reset(seed=0)
print(genv.observation_space.contains(observation))
"""
    environment = dict(os.environ, PYTHONPATH=str(tmp_path), VISCERA_PLUGIN_LIBRARY=str(viscera.PLUGIN_LIBRARY))
    done = subprocess.run([sys.executable, "-c", code, str(copy)], capture_output=True, text=True, timeout=600,
                          cwd=tmp_path, env=environment)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["True", "False", "tiny_reach", "False", "tiny_reach", "True", "TinyReach",
                                   "target_coverage", "True", "5", "True"]


def test_one_factory_builds_every_task_with_its_own_options():
    """viscera.tasks.load and each task module's load build through base.build: the shared
    options for every task, a task's own (clear_area's end_on_success) for it alone, refused
    elsewhere as Python refuses an unknown keyword."""
    env = viscera.tasks.clear_area.load(seed=0, time_limit=0.5, end_on_success=False)
    assert type(env.task) is viscera.tasks.clear_area.ClearArea and not env.task.end_on_success
    assert env.time_limit_s == pytest.approx(0.5) and env.control_timestep() == pytest.approx(0.02)
    assert viscera.tasks.load("grasp_lift", control_timestep=0.04).time_limit_s == pytest.approx(15.0)
    for name, option in (("grasp_lift", "end_on_success"), ("clear_area", "random"), ("run_the_bowel", "pixel")):
        with pytest.raises(TypeError, match=rf"^load\(\) got an unexpected keyword argument '{option}'$"):
            viscera.tasks.load(name, **{option: False})
    with pytest.raises(TypeError, match=r"unexpected keyword argument 'end_on_success'"):
        viscera.tasks.grasp_lift.load(end_on_success=False)


def test_each_step_measures_the_bowel_once(monkeypatch):
    """The condition, the reward and the observation of a step read one Measurements record: the
    target's coverage is computed once per control step, though retract_reach reads it in all
    three, and in the plugin, without the dense axis in numpy."""
    calls = collections.Counter()
    dense_axis, coverage = base.Physics.dense_axis, base.Physics.coverage

    def counted_axis(physics):
        calls["dense_axis"] += 1
        return dense_axis(physics)

    def counted_coverage(physics, points=None, axis=None):
        calls["coverage"] += points is None  # the target's; the target's placement tries others
        return coverage(physics, points, axis)

    monkeypatch.setattr(base.Physics, "dense_axis", counted_axis)
    monkeypatch.setattr(base.Physics, "coverage", counted_coverage)
    env = viscera.tasks.load("retract_reach", seed=0, time_limit=1.0)
    env.reset()
    calls.clear()
    records = []
    for action in random_actions(env, 5, 10):
        step = env.step(action)
        records.append(env.task.measurements(env.physics))
        assert 0.0 <= env.task.potential(env.physics) <= 1.0
    assert calls == {"coverage": 10}
    assert len({id(record) for record in records}) == 10  # a new record each step


@pytest.mark.parametrize("randomize", [True, False])
def test_the_measurements_are_of_the_state_observed(randomize):
    """After a reset and after each step, the observation's coverage is the physics' own,
    measured anew from its state, never an earlier state's."""
    env = viscera.tasks.load("clear_area", seed=2, time_limit=1.0, randomize=randomize)
    actions = random_actions(env, 3, 5)
    for act in [env.reset] + [lambda action=action: env.step(action) for action in actions] + [env.reset]:
        step = act()
        fresh = env.physics.coverage(env.physics.target_points()[:, :2], axis=env.physics.dense_axis())
        np.testing.assert_array_equal(step.observation["target_coverage"], fresh)
        assert env.task.measurements(env.physics).uncovered_fraction == float(1.0 - fresh.mean())


def full_state(env) -> np.ndarray:
    model, data = env.physics.model.ptr, env.physics.data.ptr
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state = np.empty(mujoco.mj_stateSize(model, spec))
    mujoco.mj_getState(model, data, state, spec)
    return state


@pytest.mark.parametrize("name", viscera.tasks.ALL)
def test_specs_and_rewards_conform(name):
    env = viscera.tasks.load(name, seed=0, time_limit=1.0)
    step = env.reset()
    specs = env.observation_spec()
    assert not env.task.success(env.physics)  # nothing is done at reset
    for action in random_actions(env, 1, 20):
        for key, spec in specs.items():
            spec.validate(step.observation[key])  # shape and dtype as declared
        step = env.step(action)
        low, high = env.task.contract.step_bounds()  # random actions do not succeed in a second
        assert low <= step.reward <= high and 0.0 <= env.task.potential(env.physics) <= 1.0
        assert all(np.isfinite(value).all() for value in step.observation.values())


@pytest.mark.parametrize("name", viscera.tasks.ALL)
def test_same_seed_same_episode_bit_for_bit(name):
    """Two loads with one seed: the same start (the whole physics state and the model's tissue,
    tilt and target) and the same steps; a reseeded reset restores it."""
    runs = []
    for _ in range(2):
        env = viscera.tasks.load(name, seed=3, time_limit=1.0)
        first = env.reset().observation
        start = full_state(env)
        for action in random_actions(env, 7, 25):
            env.step(action)
        runs.append((first, start, full_state(env), env.physics.model.opt.gravity.copy()))
        viscera.tasks.reseed(env, 3)
        again = env.reset().observation
        for key in first:
            np.testing.assert_array_equal(again[key], first[key])
    for key in runs[0][0]:
        np.testing.assert_array_equal(runs[0][0][key], runs[1][0][key])
    for a, b in zip(runs[0][1:], runs[1][1:]):
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("name", viscera.tasks.ALL)
def test_seeds_draw_distinct_episodes(name):
    """Different seeds: different bowels, tilts and (where the task has one) targets."""
    starts = []
    for seed in range(4):
        env = viscera.tasks.load(name, seed=seed, time_limit=0.5)
        observation = env.reset().observation
        starts.append((observation["intestine_axis"], observation["gravity"], observation.get("target")))
    for i in range(4):
        for j in range(i):
            assert not np.array_equal(starts[i][0], starts[j][0])
            assert not np.array_equal(starts[i][1], starts[j][1])
            if starts[i][2] is not None:
                assert not np.array_equal(starts[i][2], starts[j][2])


@pytest.mark.parametrize("name", viscera.tasks.ALL)
def test_random_actions_do_not_break_it(name):
    """A random-action episode: no NaN, no divergence, the intestine stays in the cavity."""
    env = viscera.tasks.load(name, seed=1, time_limit=2.0)
    env.reset()
    for action in random_actions(env, 2, 100):
        step = env.step(action)
        if step.last():
            break
    gut = env.physics.intestine()
    axis = env.physics.axis_points(1000)
    assert gut.divergence_count(env.physics.data.ptr) == 0
    assert (np.abs(axis[:, 0]) < 0.15).all() and (np.abs(axis[:, 1]) < 0.125).all()
    assert axis[:, 2].min() > 0.0 and axis[:, 2].max() < 0.15


def test_random_actions_need_no_recovery():
    """A learning agent's first hours, short: uniform random actions, 300 control steps on 6
    seeds per task (seeds nothing was tuned on): not one divergence recovery. The committed
    50-seed run is docs/tasks/random_stability.json. Before, some episodes stormed: a depth
    slide driven at 10 m/s through the bowel, and piles squeezed under a tool whose contact
    damping added up past its explicit limit, recovered on most steps for the rest of the episode."""
    import task_rates
    table = task_rates.rates(viscera.tasks.ALL, range(9100, 9106), ("random",), workers=2, quiet=True,
                             max_steps=300)
    for task, rows in table.items():
        assert rows["random"]["min_control_steps"] >= 300, (task, rows)
        assert rows["random"]["recoveries_total"] == 0 and rows["random"]["divergences_total"] == 0, (task, rows)


def test_the_rates_time_limit_factor_sets_the_episode_length():
    """task_rates.py --time-limit-factor F plays each episode for F times its task's time limit:
    doing nothing never succeeds, so the episode lasts exactly that long (grasp_lift's 15 s x 0.04,
    30 control steps of 20 ms)."""
    import task_rates
    row = task_rates.episode("grasp_lift", 9100, "nothing", time_limit_factor=0.04)
    assert not row["success"] and row["control_steps"] == 30
    assert row["simulated_s"] == pytest.approx(viscera.tasks.base.SUITE["grasp_lift"].TIME_LIMIT_S * 0.04, abs=1e-9)


@pytest.mark.parametrize("name, seed, actions_seed, control_steps", [("clear_area", 7, 3, 1500),
                                                                   ("run_the_bowel", 2007, 2007, 300)])
def test_the_reported_storms_are_gone(name, seed, actions_seed, control_steps):
    """The two episodes the issue reported, as a new user ran them (numpy's default_rng actions):
    13,241 recoveries in clear_area's first 15,000 physics steps, 2,312 in run_the_bowel's
    first 3,000. Now none, and the bowel never moves faster than the tools could push it."""
    env = viscera.tasks.load(name, seed=seed)
    spec = env.action_spec()
    rng = np.random.default_rng(actions_seed)
    env.reset()
    gut = env.physics.intestine()
    fastest = 0.0
    for _ in range(control_steps):
        if env.step(rng.uniform(spec.minimum, spec.maximum)).last():
            env.reset()
        fastest = max(fastest, float(np.abs(gut.velocities(env.physics.data.ptr)).max()))
    assert gut.recovery_count(env.physics.data.ptr) == 0 and gut.divergence_count(env.physics.data.ptr) == 0
    assert fastest < 2.0  # m/s


def test_the_tools_follow_an_action_at_their_top_speed():
    """An action across the whole range moves each target by its top speed times the control
    step (a hand's pace), the jaws at once; the scripted policies plan within 1/1.25 of it."""
    from viscera.tasks import policies
    env = viscera.tasks.load("run_the_bowel", seed=3)
    env.reset()
    physics = env.physics
    before = physics.data.ctrl.copy()
    spec = env.action_spec()
    env.step(spec.maximum)
    moved = physics.data.ctrl - before
    for i in range(physics.model.nu):
        coordinate = physics.model.id2name(i, "actuator").rsplit("_", 1)[-1]
        speed = base.BowelTask.TOOL_SPEED[coordinate]
        expected = min(spec.maximum[i] - before[i], speed * env.control_timestep())
        assert moved[i] == pytest.approx(expected, abs=1e-12), coordinate
        if coordinate != "jaw":
            planned = policies.LIMITS[coordinate] if coordinate == "depth" else np.radians(policies.LIMITS[coordinate])
            assert speed == pytest.approx(1.25 * planned)


def _rates(policy: str, seeds: range) -> dict:
    import task_rates  # python/tools, on the path through conftest
    return task_rates.rates(viscera.tasks.ALL, seeds, (policy,), workers=2, quiet=True)


def test_random_actions_rarely_succeed():
    """Uniform random actions succeed on fewer than 5 % of 20 seeds in every task (none of 20,
    then; the committed 50-seed rates are in docs/tasks/rates.json)."""
    for task, table in _rates("random", range(100, 120)).items():
        assert table["random"]["success_rate"] < 0.05, (task, table)


def test_doing_nothing_never_succeeds():
    for task, table in _rates("nothing", range(100, 105)).items():
        assert table["nothing"]["success_rate"] == 0.0, (task, table)


def test_scripted_policies_generalise():
    """Each task's scripted policy on 10 seeds it was not tuned on (tuning used seeds below 200):
    at least 8 successes each (the committed 50-seed rates are in docs/tasks/rates.json). Ten, not
    five: at 0.3.0's friction grasp clear_area's rate is 96 % on seeds 1000-1049 and 90 % on
    2000-2019, and its two failures there are 2001 and 2003, so five seeds read 60 %."""
    for task, table in _rates("scripted", range(2000, 2010)).items():
        assert table["scripted"]["success_rate"] >= 0.8, (task, table)


@pytest.mark.parametrize("name, seed", [("grasp_lift", 0), ("run_the_bowel", 0), ("clear_area", 0),
                                        ("retract_reach", 0)])
def test_scripted_policies_succeed(name, seed):
    """The scripted policies, closed loop from the observations, on a seed each."""
    env = viscera.tasks.load(name, seed=seed)
    policy = viscera.tasks.scripted_policy(env)
    step = env.reset()
    while not step.last():
        step = env.step(policy(step))
    assert env.task.success(env.physics) and step.discount == 0.0  # ended by its success


def test_the_scripted_gesture_clears_the_shipped_scene_and_again_after_a_reset():
    """The clearing gesture on the shipped scene (randomize=False: the paper's cavity as it
    ships): a lasting success (80 % uncovered, jaws open, tools clear, for 2 s) that ends the
    episode, the same again after a reset (the same oracle: it keeps nothing of an episode but
    its count of releases, which no decision reads)."""
    env = viscera.tasks.load("clear_area", seed=0, randomize=False)
    policy = ClearingGesture(env)
    results = []
    for _ in range(2):
        step = env.reset()
        released = policy.cycles
        while not step.last():
            step = env.step(policy(step))
        results.append((env.task.measurements(env.physics).uncovered_fraction, env.physics.data.time,
                        policy.cycles - released, env.task.success(env.physics)))
    uncovered, seconds, cycles, success = results[0]
    assert success and uncovered >= 0.8 and seconds < 30.0 and cycles >= 1
    assert results[1] == results[0]


def test_play_command_plays_the_whole_episode_and_says_whether_it_succeeded():
    """`python -m viscera play TASK` plays the task's own episode (its time limit, not a
    shorter default) with its scripted policy and ends with the verdict; the exit status says
    it too: 0 for a success, 1 for a failure (idle tools never succeed)."""
    def play(*args):
        return subprocess.run([sys.executable, "-m", "viscera", "play", "grasp_lift", "--quiet", *args],
                              capture_output=True, text=True, timeout=600)
    done = play("--seed", "0")
    assert done.returncode == 0, done.stderr
    lines = done.stdout.strip().splitlines()
    assert lines[-1].startswith("success: yes (grasp_lift: ")
    # it ran until the success, not a fixed duration: the episode docs/tasks/pictures.json quotes
    # (test_docs checks that figure against the code)
    import json
    shown = json.loads((ROOT / "docs" / "tasks" / "pictures.json").read_text())["grasp_lift"]
    assert shown["seed"] == 0 and f"{round(shown['simulated_s'] / 0.02)} ticks" in lines[0]
    idle = play("--seed", "0", "--policy", "idle", "--time-limit", "1")
    assert idle.returncode == 1, idle.stderr
    assert idle.stdout.strip().splitlines()[-1].startswith("success: no")


def test_the_environment_steps_under_mujoco_rollout():
    """The task's model and state under mujoco.rollout on two threads, three control
    sequences: each matches stepping one MjData alone."""
    env = viscera.tasks.load("clear_area", seed=0)
    env.reset()
    model, data = env.physics.model.ptr, env.physics.data.ptr
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    initial = np.empty(mujoco.mj_stateSize(model, spec))
    mujoco.mj_getState(model, data, initial, spec)
    controls = np.stack([np.tile(action, (150, 1)) for action in random_actions(env, 4, 3)])
    states, _ = rollout.rollout(model, [mujoco.MjData(model) for _ in range(2)], np.tile(initial, (3, 1)), controls)
    for i in range(3):
        alone = mujoco.MjData(model)
        mujoco.mj_setState(model, alone, initial, spec)
        for t in range(150):
            alone.ctrl[:] = controls[i, t]
            mujoco.mj_step(model, alone)
        expected = np.empty_like(initial)
        mujoco.mj_getState(model, alone, expected, spec)
        np.testing.assert_allclose(states[i, -1], expected, rtol=0, atol=1e-9)


def test_doing_nothing_leaves_the_area_covered():
    env = viscera.tasks.load("clear_area", seed=0, time_limit=2.0, randomize=False)
    env.reset()
    zeros = np.zeros(env.action_spec().shape)
    while True:
        step = env.step(zeros)
        if step.last():
            break
    assert env.task.measurements(env.physics).uncovered_fraction < 0.2


def test_environments_do_not_share_state():
    """Two environments stepped in turn behave as each alone."""
    alone = viscera.tasks.load("clear_area", seed=5, time_limit=1.0)
    alone.reset()
    actions = random_actions(alone, 9, 15)
    for action in actions:
        expected = alone.step(action).observation
    a = viscera.tasks.load("clear_area", seed=5, time_limit=1.0)
    b = viscera.tasks.load("clear_area", seed=6, time_limit=1.0)
    a.reset()
    b.reset()
    for action in actions:
        got = a.step(action).observation
        b.step(-action)
    for key in expected:
        np.testing.assert_array_equal(got[key], expected[key])


@pytest.mark.parametrize("task", viscera.tasks.ALL)
def test_a_scripted_policy_acts_on_the_time_steps_alone(task):
    """The scripted policies are demonstrators for learning: built on one environment of a task
    (seed 3), handed the time steps of another (seed 7), a policy acts exactly as one built on
    that other: it reads the observations and the scene's fixed geometry, no state of the
    environment it was built on. 300 control steps (6 s) of each task."""
    built_elsewhere = viscera.tasks.scripted_policy(viscera.tasks.load(task, seed=3))
    env = viscera.tasks.load(task, seed=7)
    own = viscera.tasks.scripted_policy(env)
    step = env.reset()
    for _ in range(300):
        action = own(step)
        assert np.array_equal(built_elsewhere(step), action)
        step = env.step(action)
        if step.last():
            break


@pytest.mark.parametrize("name", viscera.tasks.ALL)
def test_every_tool_starts_in_the_laparoscopes_view(name):
    """At every episode's start the laparoscope sees each tool: with the other tools' geoms not
    drawn (group 5), its segmentation shows the tool, and a grasper's jaw alone shows too (not a
    loop in front of them); the working point projects inside the image; the tool is inserted at a
    working depth and at rest, held where it is (ctrl = qpos)."""
    import math
    from viscera.pixels import LABELS, Camera
    camera_view = Camera(84, 84, "laparoscope")
    for seed in range(1000, 1020):  # 20 unseen seeds
        env = viscera.tasks.load(name, seed=seed)
        env.reset()
        physics = env.physics
        model, data = physics.model.ptr, physics.data.ptr
        groups = model.geom_group.copy()
        for tool in physics.tools():
            own = [i for i in range(model.ngeom) if model.geom(i).name.startswith(f"{tool}_")]
            jaw = [i for i in own if model.geom(i).name == f"{tool}_jaw"]
            tools = np.isin(model.body_rootid[model.geom_bodyid], [model.body(f"{t}_trocar").id for t in physics.tools()])
            for shown, least in ((own, 20), (jaw, 1)):
                if not shown:
                    continue
                model.geom_group[:] = np.where(tools & ~np.isin(np.arange(model.ngeom), shown), 5, groups)
                seen = (camera_view.render(physics)["segmentation"] == LABELS["tool"]).sum()
                model.geom_group[:] = groups
                assert seen >= least, (tool, seed, shown, seen)
            eye, frame = data.cam_xpos[model.camera("laparoscope").id], data.cam_xmat[model.camera("laparoscope").id]
            local = ((physics.working_point(tool) - eye)[:, None] * frame.reshape(3, 3)).sum(axis=0)
            focal = 42.0 / math.tan(math.radians(float(model.cam_fovy[model.camera("laparoscope").id])) / 2.0)
            column, row = 42.0 + focal * local[0] / -local[2], 42.0 - focal * local[1] / -local[2]
            assert 0 <= column < 84 and 0 <= row < 84 and local[2] < 0, (tool, seed, column, row)
            depth = np.asarray(physics.named.data.qpos[f"{tool}_depth"]).item()
            assert depth >= base.READY_MIN_DEPTH_M
            for coordinate in ("pitch", "yaw", "depth"):
                assert np.asarray(physics.named.data.ctrl[f"{tool}_{coordinate}"]).item() == np.asarray(
                    physics.named.data.qpos[f"{tool}_{coordinate}"]).item()
        assert not np.any(data.qvel[physics.tool_index().joint_dof])
    camera_view.close()


def test_what_the_score_counts_as_seen_is_what_the_camera_draws():
    """Physics.tool_seen (the score's visibility: some of the tool's last 2 cm in the image, no
    loop across the line of sight) against the segmentation the laparoscope draws of the tool's
    jaw or paddle alone (the other tools hidden): every 15th tick of three scripted episodes, with
    the tool inserted. They agree on at least 90 % of the samples, and a tool the score counts as
    seen shows in the image nearly always; the working point alone agreed on 74 %."""
    from viscera.pixels import LABELS, Camera
    camera_view = Camera(96, 96, "laparoscope")
    counts = collections.Counter()
    for name, seed in (("clear_area", 0), ("retract_reach", 1), ("run_the_bowel", 2)):
        env = viscera.tasks.load(name, seed=seed)
        policy = viscera.tasks.scripted_policy(env)
        step = env.reset()
        physics = env.physics
        model = physics.model.ptr
        groups = model.geom_group.copy()
        tools = np.isin(model.body_rootid[model.geom_bodyid], [model.body(f"{t}_trocar").id for t in physics.tools()])
        for tick in range(1, 1501):
            step = env.step(policy(step))
            if step.last():
                break
            if tick % 15:
                continue
            axis = physics.dense_axis()
            for tool in physics.tools():
                if np.asarray(physics.named.data.qpos[f"{tool}_depth"]).item() < 0.02:
                    continue
                end = [i for i in range(model.ngeom) if model.geom(i).name in (f"{tool}_jaw", f"{tool}_paddle")]
                model.geom_group[:] = np.where(tools & ~np.isin(np.arange(model.ngeom), end), 5, groups)
                drawn = bool((camera_view.render(physics)["segmentation"] == LABELS["tool"]).any())
                model.geom_group[:] = groups
                counts[(physics.tool_seen(tool, axis), drawn)] += 1
    camera_view.close()
    total = sum(counts.values())
    assert total > 200, counts
    assert (counts[(True, True)] + counts[(False, False)]) / total >= 0.9, counts
    assert counts[(True, False)] <= 0.02 * total, counts
