"""Pickled and deep-copied data carry the intestine and never share its caches.

Pickling copies MuJoCo's raw plugin_data pointer into the copy; the plugin must
neither double-free it at exit nor read through it. Each case runs in a fresh
interpreter so that a crash (abort at exit) fails the test instead of pytest.
"""

import subprocess
import sys
import textwrap

import pytest

PRELUDE = """
import copy, pickle, mujoco, numpy as np, viscera
xml = '<mujoco><worldbody><geom type="plane" size="2 2 .1"/></worldbody>' + viscera.extension_xml(
    'g', length=1, control_points=20, shape='line', start=[0, 0, 0.3]) + '</mujoco>'
m = mujoco.MjModel.from_xml_string(xml)
d = mujoco.MjData(m)
gut = viscera.intestine(m)
def step(data, count):
    for _ in range(count):
        mujoco.mj_step(m, data)
step(d, 50)
"""

CASES = {
    "copy_deleted_first": """
        c = pickle.loads(pickle.dumps(d))
        step(c, 30); step(d, 30)
        assert np.array_equal(gut.positions(c), gut.positions(d))
        del c
        step(d, 30)
        assert np.isfinite(gut.positions(d)).all()
    """,
    "original_deleted_first": """
        c = pickle.loads(pickle.dumps(d))
        reference = mujoco.MjData(m); mujoco.mj_copyData(reference, m, d)
        del d
        step(c, 30); step(reference, 30)
        assert np.array_equal(gut.positions(c), gut.positions(reference))
        mujoco.mj_resetData(m, c)
        assert np.allclose(gut.positions(c)[0], [0, 0, 0.3])
    """,
    "deepcopy_and_dm_control_physics": """
        from dm_control import mujoco as dm_mujoco
        c = copy.deepcopy(d)
        step(c, 30); step(d, 30)
        assert np.array_equal(gut.positions(c), gut.positions(d))
        assert np.array_equal(c.plugin_state, d.plugin_state)
        physics = dm_mujoco.Physics.from_xml_string(xml)
        for _ in range(20): physics.step()
        twin = pickle.loads(pickle.dumps(physics))
        for _ in range(20): physics.step(); twin.step()
        assert np.array_equal(viscera.intestine(physics.model.ptr).positions(physics.data.ptr),
                              viscera.intestine(twin.model.ptr).positions(twin.data.ptr))
        del physics
        twin.reset()
        for _ in range(5): twin.step()
    """,
    "cavity_task_physics_copies": """
        import viscera.tasks
        env = viscera.tasks.load("clear_area", seed=0)
        spec = env.action_spec(); rng = np.random.default_rng(0)
        env.reset()
        for _ in range(10): env.step(rng.uniform(spec.minimum, spec.maximum))
        physics = env.physics
        twins = [physics.copy(share_model=True), physics.copy(share_model=False), copy.deepcopy(physics),
                 pickle.loads(pickle.dumps(physics))]
        actions = rng.uniform(spec.minimum, spec.maximum, (60, spec.shape[0]))
        for action in actions:
            for p in [physics] + twins:
                p.set_control(action); p.step()
        for twin in twins:
            assert np.array_equal(twin.data.plugin_state, physics.data.plugin_state)
            assert np.array_equal(twin.data.qpos, physics.data.qpos)
        del twins[1], physics
        for twin in twins:
            twin.step()
    """,
    "steps_take_no_lock": """
        from viscera import _library
        locks = _library.native().viscera_cache_locks_taken
        c = pickle.loads(pickle.dumps(d))
        step(c, 1)  # a pickled copy's first step finds its own caches (under the lock, once)
        datas = [mujoco.MjData(m) for _ in range(4)]
        before = locks()
        step(d, 100); step(c, 100)
        mujoco.mj_forward(m, d)
        state = np.zeros((4, mujoco.mj_stateSize(m, mujoco.mjtState.mjSTATE_FULLPHYSICS)))
        for i, data in enumerate(datas):
            mujoco.mj_getState(m, data, state[i], mujoco.mjtState.mjSTATE_FULLPHYSICS)
        from mujoco import rollout
        rollout.rollout(m, datas, state, nstep=50)  # on four threads
        assert locks() == before, (before, locks())
        copy_target = mujoco.MjData(m)
        taken = locks()
        mujoco.mj_copyData(copy_target, m, d)  # the copy callback reads both datas' caches lock-free
        step(copy_target, 10)
        assert locks() == taken
    """,
    "a_copy_does_not_warn_again": """
        messages = []
        mujoco.set_mju_user_warning(messages.append)
        inside = '<mujoco><worldbody><geom type="plane" size="2 2 .1"/></worldbody>' + viscera.extension_xml(
            'g', length=1, control_points=20, shape='line', start=[0, 0, 0.003]) + '</mujoco>'
        mi = mujoco.MjModel.from_xml_string(inside)
        di = mujoco.MjData(mi)
        mujoco.mj_step(mi, di)
        assert sum("starts inside geom" in text for text in messages) == 1, messages
        twin = mujoco.MjData(mi)
        mujoco.mj_copyData(twin, mi, di)
        for _ in range(3): mujoco.mj_step(mi, twin)
        assert sum("starts inside geom" in text for text in messages) == 1, messages
        fresh = mujoco.MjData(mi)
        mujoco.mj_step(mi, fresh)  # a new data checks its own start
        assert sum("starts inside geom" in text for text in messages) == 2, messages
        # a state set before the first step is the user's, not the config's start: a snapshot taken
        # while a geom pressed the tube deep (here the start itself, lowered 8 mm) gives no advice
        spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
        snapshot = np.zeros(mujoco.mj_stateSize(mi, spec))
        mujoco.mj_getState(mi, mujoco.MjData(mi), snapshot, spec)
        gut = viscera.intestines(mi)[0]
        restored = mujoco.MjData(mi)
        mujoco.mj_setState(mi, restored, snapshot, spec)
        gut.positions(restored)[:, 2] -= 0.008
        mujoco.mj_step(mi, restored)
        assert sum("starts inside geom" in text for text in messages) == 2, messages
        mujoco.set_mju_user_warning(None)
    """,
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_copies_run_independently_and_exit_cleanly(case):
    code = PRELUDE + textwrap.dedent(CASES[case]) + "\nprint('clean')\n"
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, f"exit {result.returncode}\n{result.stdout}\n{result.stderr}"
    assert "clean" in result.stdout
    assert "not stepped" not in result.stdout + result.stderr
