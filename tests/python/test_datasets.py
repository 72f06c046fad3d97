"""Demonstrations as datasets (viscera.datasets): written by LeRobot's and Minari's own writers,
read back by their own loaders and found bit for bit against the same episodes collected
apart; recordings of people become datasets; no half-written dataset; one-line errors."""

import importlib.util
import pathlib

import numpy as np
import pytest

from viscera import datasets, recording
from viscera.datasets import episodes

SIZE = (24, 32)  # small images: the test is about the bits, not the picture


def reference(task: str, seeds, pixels: bool) -> list[episodes.Episode]:
    """The episodes collected directly in this process, one environment, no writer."""
    from viscera.scale.gym_env import TaskEnv
    env = TaskEnv(**episodes.env_kwargs(task, "abdomen", pixels, SIZE))
    try:
        return [episodes.run(env, seed, "scripted") for seed in seeds]
    finally:
        env.close()


@pytest.fixture(scope="module")
def grasps():
    """Two scripted grasp_lift episodes with pixels, collected apart from any writer."""
    return reference("grasp_lift", [3, 4], pixels=True)


def test_minari_dataset_at_a_relative_path(tmp_path, monkeypatch, grasps):
    """`--out data/x`, relative to the working folder, as the README writes it: Minari joins a
    relative datasets root to itself, so a second episode's write once failed looking for
    data/x/.../data/x/.../main_data.hdf5."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "data").mkdir()
    summary = datasets.write("grasp_lift", pathlib.Path("data") / "grasps", "minari", seeds=[3, 4], pixels=False,
                             size=SIZE, workers=1)
    assert summary["episodes"] == 2
    dataset = datasets.load(pathlib.Path("data") / "grasps", "minari", "grasp_lift", "scripted")
    assert dataset.total_episodes == 2 and dataset.total_steps == sum(e.steps for e in grasps)


def test_minari_dataset_reloads_bit_for_bit(tmp_path, grasps):
    out = tmp_path / "minari"
    # two worker processes: the dataset must not depend on where an episode ran
    summary = datasets.write("grasp_lift", out, "minari", seeds=[3, 4], pixels=True, size=SIZE, workers=2)
    assert summary["episodes"] == 2 and summary["frames"] == sum(e.steps for e in grasps)
    dataset = datasets.load(out, "minari", "grasp_lift", "scripted")
    assert dataset.total_episodes == 2 and dataset.total_steps == sum(e.steps for e in grasps)
    metadata = list(dataset.storage.get_episode_metadata([0, 1]))
    for written, meta, expected in zip(dataset.iterate_episodes(), metadata, grasps):
        assert meta["seed"] == expected.seed
        assert len(written) == expected.steps and written.observations["state"].shape[0] == expected.steps + 1
        assert np.array_equal(written.observations["state"], expected.state)
        for key in ("pixels", "depth", "segmentation"):
            assert written.observations[key].dtype == expected.images[key].dtype
            assert np.array_equal(written.observations[key], expected.images[key])  # lossless, no JPEG
        assert np.array_equal(written.actions, expected.action)
        assert np.array_equal(written.rewards, expected.reward)
        assert np.array_equal(written.terminations, expected.terminated)
        assert np.array_equal(written.truncations, expected.truncated)
        assert np.array_equal(written.infos["is_success"], expected.is_success)
        for name, values in expected.privileged.items():
            assert np.array_equal(written.infos["privileged"][name], values)
        # the oracle's labels: row t + 1 labels action t, the reset's row 0 is -1, -1 and zeros
        assert sorted(written.infos["oracle"]) == sorted(episodes.ORACLE_LABELS)
        for name, values in expected.oracle.items():
            assert np.array_equal(written.infos["oracle"][name][1:], values), name
            assert np.all(written.infos["oracle"][name][0] == (0.0 if name == "aims" else -1)), name
        # a scripted grasp succeeds and the task ends it: the last step is a termination
        assert expected.success and written.terminations[-1] and not written.truncations.any()
    # the recorded environment is the one the episodes ran in: same first observation
    env = dataset.recover_environment()
    first, _ = env.reset(seed=grasps[0].seed)
    assert np.array_equal(first["state"], grasps[0].state[0])
    env.close()


def test_a_scripted_episode_carries_its_oracles_labels(grasps):
    """Each action of a scripted episode is labelled with what the oracle decided it was doing
    (viscera.tasks.oracle.Decision: the phase, the lead tool, each tool's aim); an oracle built
    anew, handed the episode's own states (the flat state the dataset keeps, unflattened), decides
    those labels and the action taken, bit for bit: the labels belong to the states they sit
    beside. Other demonstrators carry none."""
    import viscera.tasks
    from viscera.scale.gym_env import TaskEnv
    env = TaskEnv(**episodes.env_kwargs("grasp_lift", "abdomen", False, SIZE))
    phases = viscera.tasks.oracle_phases("grasp_lift")
    for expected in grasps:
        assert sorted(expected.oracle) == sorted(episodes.ORACLE_LABELS)
        assert expected.oracle["phase"].shape == expected.oracle["lead"].shape == (expected.steps,)
        assert expected.oracle["aims"].shape == (expected.steps, 1, 3)  # one tool: the grasper
        assert expected.oracle["phase"].dtype == expected.oracle["lead"].dtype == np.int64
        said = [phases[i] for i in expected.oracle["phase"]]
        assert said[0] == "approach" and said[-1] == "hold" and {"descend", "close", "lift"} <= set(said)
        oracle = viscera.tasks.scripted_policy(viscera.tasks.load("grasp_lift", seed=expected.seed))
        for t in range(expected.steps):
            decision = oracle.decide(env.unflatten(expected.state[t]))
            vector = decision.vector(oracle.PHASES, oracle.names)
            assert vector[0] == expected.oracle["phase"][t] and vector[1] == expected.oracle["lead"][t], t
            assert np.array_equal(vector[2:], expected.oracle["aims"][t].ravel()), t
            action = np.clip(env.gym_action(decision.action), -1.0, 1.0)
            assert np.array_equal(action, expected.demonstrator_action[t]), t
    env.close()
    short = TaskEnv("grasp_lift", flatten=True, time_limit=0.1)
    idle = episodes.run(short, 3, "idle")
    short.close()
    assert idle.steps == 5 and idle.oracle == {}


def test_lerobot_dataset_reloads_frame_for_frame(tmp_path):
    """Run in a fresh interpreter: LeRobot's imports (torch, PyAV, its image plugins) stay out of
    this test process, whose later viewer tests take screenshots."""
    import subprocess
    import sys
    code = ("import pathlib, sys; sys.path.insert(0, sys.argv[1]); import test_datasets as t; "
            "t.check_lerobot_dataset(pathlib.Path(sys.argv[2]), t.reference('grasp_lift', [3, 4], pixels=True))")
    result = subprocess.run([sys.executable, "-c", code, str(pathlib.Path(__file__).parent), str(tmp_path)],
                            capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stderr[-4000:]


def check_lerobot_dataset(tmp_path, grasps):
    out = tmp_path / "lerobot"
    datasets.write("grasp_lift", out, "lerobot", seeds=[3, 4], pixels=True, size=SIZE)
    dataset = datasets.load(out, "lerobot", "grasp_lift", "scripted")
    features = dataset.meta.features
    assert features["oracle.phase"]["dtype"] == features["oracle.lead"]["dtype"] == "int64"
    assert features["oracle.aims"]["dtype"] == "float32"
    assert features["oracle.aims"]["names"] == ["grasper.x", "grasper.y", "grasper.z"]  # m, per tool
    assert dataset.num_episodes == 2 and dataset.num_frames == sum(e.steps for e in grasps)
    index, decoded = 0, []
    for episode_index, expected in enumerate(grasps):
        for t in range(expected.steps):
            frame = dataset[index]
            index += 1
            assert int(frame["episode_index"]) == episode_index and int(frame["frame_index"]) == t
            assert int(frame["seed"]) == expected.seed
            # LeRobot keeps float32: the values written, bit for bit
            assert np.array_equal(frame["observation.state"].numpy(), expected.state[t].astype(np.float32))
            assert np.array_equal(frame["action"].numpy(), expected.action[t].astype(np.float32))
            assert float(frame["next.reward"]) == np.float32(expected.reward[t])
            assert bool(frame["next.success"]) == expected.is_success[t + 1]
            assert np.array_equal(frame["observation.depth"].numpy(), expected.images["depth"][t])
            assert np.array_equal(frame["observation.segmentation"].numpy(), expected.images["segmentation"][t])
            assert np.array_equal(frame["privileged.control_points"].numpy(),
                                  expected.privileged["control_points"][t].astype(np.float32))
            assert int(frame["oracle.phase"]) == expected.oracle["phase"][t]  # what the oracle said it did
            assert int(frame["oracle.lead"]) == expected.oracle["lead"][t]
            aims = expected.oracle["aims"][t].ravel().astype(np.float32)
            assert np.array_equal(frame["oracle.aims"].numpy(), aims)
            decoded.append(np.round(frame["observation.images.laparoscope"].numpy().transpose(1, 2, 0) * 255.0))
        assert bool(dataset[index - 1]["next.done"]) and bool(dataset[index - 1]["next.success"])
        # RGB is video (LeRobot's AV1, lossy): each decoded frame is its written frame within the
        # codec's error (PSNR over 20 dB), and nearer to it than to the next one (no frame shifted)
        decoded, written = np.asarray(decoded), expected.images["pixels"][:expected.steps].astype(float)
        assert decoded.shape == written.shape
        mse = np.mean((decoded - written) ** 2, axis=(1, 2, 3))
        assert np.all(10 * np.log10(255.0 ** 2 / np.maximum(mse, 1e-12)) > 20.0)
        assert mse[:-1].sum() < np.mean((decoded[:-1] - written[1:]) ** 2, axis=(1, 2, 3)).sum()
        decoded = []


def test_recordings_of_people_become_a_dataset(tmp_path):
    folder = tmp_path / "sessions"
    folder.mkdir()
    taken = recording.record("grasp_lift", seed=5, policy="scripted", time_limit_s=3.0)
    taken.policy = "person:keyboard"  # what a teleop session stores: the file, not who made it, is replayed
    taken.save(folder / "session.npz")
    out = tmp_path / "people"
    summary = datasets.write("grasp_lift", out, "minari", recordings=folder)
    assert summary["demonstrator"] == "recordings" and summary["episodes"] == 1
    written = next(datasets.load(out, "minari", "grasp_lift", "recordings").iterate_episodes())
    from viscera.scale.gym_env import TaskEnv
    env = TaskEnv("grasp_lift")
    expected = np.clip(env.gym_action(taken.actions), -1.0, 1.0)
    env.close()
    # every recorded command, normalised, and nothing more: the time limit cut it (truncated)
    assert np.array_equal(written.actions, expected)
    assert written.truncations[-1] and not written.terminations.any()


def test_recordings_that_do_not_replay_or_differ_are_refused(tmp_path):
    folder = tmp_path / "sessions"
    folder.mkdir()
    short = recording.record("grasp_lift", seed=5, policy="idle", time_limit_s=0.2)
    short.save(folder / "a.npz")
    longer = recording.record("grasp_lift", seed=6, policy="idle", time_limit_s=0.3)
    longer.save(folder / "b.npz")
    with pytest.raises(datasets.DatasetError, match="b.npz differs from a.npz in time_limit 0.3 against 0.2"):
        datasets.write("grasp_lift", tmp_path / "mixed", "minari", recordings=folder)
    (folder / "b.npz").unlink()
    short.final_state_sha256 = "0" * 64  # as if recorded by another version
    short.save(folder / "a.npz")
    with pytest.raises(datasets.DatasetError, match="recordings 'a.npz': its replay does not end in the recorded state"):
        datasets.write("grasp_lift", tmp_path / "stale", "minari", recordings=folder, workers=2)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sessions"]  # no dataset, no staging folder


def test_an_interrupted_collection_leaves_no_dataset(tmp_path, monkeypatch):
    real_run, calls = episodes.run, []

    def interrupted(*args, **kwargs):
        calls.append(1)
        if len(calls) == 2:
            raise KeyboardInterrupt  # Ctrl-C after the first episode was written
        return real_run(*args, **kwargs)

    monkeypatch.setattr(episodes, "run", interrupted)
    # minari only in this process: LeRobot's imports would stay in it (see the LeRobot test)
    for format in ("minari",):
        calls.clear()
        out = tmp_path / format
        with pytest.raises(KeyboardInterrupt):
            datasets.write("grasp_lift", out, format, seeds=[0, 1, 2])
        assert len(calls) == 2 and not out.exists()
        assert list(tmp_path.iterdir()) == []  # nor the staging folder


def run_cli(capsys, *argv):
    from viscera.__main__ import main
    with pytest.raises(SystemExit) as stopped:
        main(["dataset", *argv])
    return stopped.value.code, capsys.readouterr().err.strip().splitlines()


@pytest.mark.parametrize("argv, expected", [
    (["bowel", "--format", "minari", "--out", "x"], "argument TASK: invalid choice 'bowel'"),
    (["grasp_lift", "--format", "minari", "--out", "x", "--seeds", "9:3"], "--seeds: must be A:B with 0 <= A < B"),
    (["grasp_lift", "--format", "minari", "--out", "x", "--seeds", "1-5"], "--seeds: must be A:B, two integers"),
    (["grasp_lift", "--format", "minari", "--out", "/proc/viscera-dataset"], "--out '/proc/viscera-dataset': folder '/proc' is not writable"),
    (["grasp_lift", "--format", "minari", "--out", "/no/such/folder/x"], "--out '/no/such/folder/x': folder '/no/such/folder' does not exist"),
    (["grasp_lift", "--format", "minari", "--out", "x", "--policy", "expert"], "--policy 'expert': must be one of"),
    (["grasp_lift", "--format", "minari", "--out", "x", "--episodes", "4", "--seeds", "0:2"], "--episodes 4 is more than --seeds 0:2 gives (2)"),
    (["grasp_lift", "--format", "minari", "--out", "x", "--policy", "recordings", "/no/such"], "--policy recordings '/no/such': not a folder"),
    (["grasp_lift", "--format", "minari", "--out", "x", "--policy", "recordings", ".", "--scene", "anatomical"], "--scene with --policy recordings"),
    (["grasp_lift", "--format", "minari", "--out", "x", "--size", "64x64"], "--size 64x64 needs --pixels"),
    (["grasp_lift", "--format", "minari", "--out", "x", "--action-noise", "2"], "--action-noise: must be from 0 to 1"),
])
def test_dataset_command_mistakes_are_one_line(capsys, argv, expected):
    status, lines = run_cli(capsys, *argv)
    assert status == 2 and len(lines) == 1 and expected in lines[0], lines


def test_dataset_command_names_the_missing_extra(capsys, monkeypatch, tmp_path):
    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "lerobot" else real(name, *a))
    status, lines = run_cli(capsys, "grasp_lift", "--format", "lerobot", "--out", str(tmp_path / "x"))
    assert status == 2 and lines == ["python -m viscera dataset: error: --format 'lerobot': needs the lerobot extra, "
                                     "not installed: pip install \"viscera[lerobot]\""]


def test_existing_out_is_refused(capsys, tmp_path):
    status, lines = run_cli(capsys, "grasp_lift", "--format", "minari", "--out", str(tmp_path))
    assert status == 2 and len(lines) == 1 and "exists: a dataset is written to a new path" in lines[0]


def test_ctrl_c_mid_collection_leaves_nothing(tmp_path):
    """Ctrl-C at a terminal signals the whole process group, the worker processes too: the
    command ends in one line with status 130, and leaves neither a dataset nor its staging folder."""
    import os
    import signal
    import subprocess
    import sys
    import time

    process = subprocess.Popen([sys.executable, "-m", "viscera", "dataset", "grasp_lift", "--format", "minari",
                                "--out", str(tmp_path / "d"), "--seeds", "0:40", "--workers", "2", "--quiet"],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
                               # as from a terminal: Ctrl-C's default action, whatever this process inherited
                               preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    deadline = time.monotonic() + 300
    while not list(tmp_path.glob(".d.partial-*/dataset/**/main_data.hdf5")):  # the first episode is written
        assert process.poll() is None and time.monotonic() < deadline, process.communicate()
        time.sleep(0.1)
    os.killpg(process.pid, signal.SIGINT)
    try:
        _, stderr = process.communicate(timeout=120)  # the episodes running finish, the queued ones are dropped
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, signal.SIGKILL)
        raise
    assert process.returncode == 130 and stderr.strip().splitlines() == ["python -m viscera dataset: interrupted"]
    assert list(tmp_path.iterdir()) == []
