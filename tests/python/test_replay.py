"""Recordings replay bit for bit, for every task and every kind of policy (a person's included);
a bad recording is refused with one line naming what is wrong; the motion comes out as
ToolTrajectory files that play the recorded commands back."""

from __future__ import annotations

import json
import zipfile

import numpy as np
import pytest

import viscera.tasks
from viscera import recording as rec
from viscera.trajectory import ToolTrajectory


@pytest.mark.parametrize("task", viscera.tasks.ALL)
@pytest.mark.parametrize("policy", rec.POLICIES)
def test_a_recording_replays_bit_identically(task, policy, tmp_path):
    """Every task with every policy kind: 3 simulated seconds each (grasp_lift's script to its end)."""
    limit = None if (task, policy) == ("grasp_lift", "scripted") else 3.0
    recording = rec.record(task, seed=1001, policy=policy, time_limit_s=limit)
    path = tmp_path / "episode.npz"
    recording.save(path)
    loaded = rec.load(path)
    assert loaded.final_state_sha256 == recording.final_state_sha256 and len(recording.final_state_sha256) == 64
    np.testing.assert_array_equal(loaded.actions, recording.actions)
    result = rec.replay(loaded)
    assert result.steps == recording.steps
    assert result.final_state_sha256 == recording.final_state_sha256
    assert result.success == recording.success
    if (task, policy) == ("grasp_lift", "scripted"):
        assert recording.success  # the script lifts the band on this unseen seed


def test_different_actions_give_a_different_digest():
    """The digest is of the state: one changed action in the middle changes it. The jaw's: the
    other coordinates' targets move at the tools' top speed toward a random action, so a small
    change of a far target leaves the move as it was (BowelTask.TOOL_SPEED)."""
    recording = rec.record("grasp_lift", seed=3, policy="random", time_limit_s=0.5)
    changed = rec.Recording(**{**recording.__dict__, "actions": recording.actions.copy()})
    changed.actions[10, 4] += -0.01 if changed.actions[10, 4] > 0.0 else 0.01  # grasper_jaw
    assert rec.replay(changed).final_state_sha256 != recording.final_state_sha256


def test_a_persons_session_replays_bit_identically():
    """A live session (viscera.teleop) records what its device drove; replay ends in its state."""
    from viscera.teleop import devices
    from viscera.teleop.session import Session
    keyboard = devices.KeyboardDevice()
    session = Session("retract_reach", seed=7, device=keyboard, time_limit_s=1.5)
    for key in [devices.KEY_HOME] * 8 + [devices.KEY_UP, devices.KEY_ENTER, devices.KEY_PAGE_DOWN, devices.KEY_HOME]:
        keyboard.key(key)
    while not session.time_step.last():
        session.tick()
    result = session.result(session.ended())
    recording = result.recording
    assert recording.policy == "person:keyboard" and recording.steps == 150
    assert np.ptp(recording.actions, axis=0).max() > 0.0  # the tools moved
    assert rec.replay(recording).final_state_sha256 == recording.final_state_sha256


def test_trajectories_play_the_recorded_commands_back(tmp_path):
    """Each tool's file, read back by ToolTrajectory, passes within the tolerance of every tick's
    command at the tick's end, with far fewer waypoints than ticks."""
    import mujoco
    recording = rec.record("grasp_lift", seed=4, policy="scripted", time_limit_s=4.0)
    files = rec.trajectories(recording)
    model = rec.load_task("grasp_lift", 4).physics.model.ptr
    assert set(files) == {"grasper"}
    checked = 0
    for tool, spec in files.items():
        path = tmp_path / f"{tool}.json"
        path.write_text(json.dumps(spec))
        trajectory = ToolTrajectory.from_file(str(path))
        assert trajectory.delay == 0.0  # its velocity limits never stretch it
        assert len(spec["waypoints"]) < 0.8 * recording.steps  # the still and eased stretches simplified
        ends = (np.arange(recording.steps) + 1) * recording.control_timestep_s
        played = np.array([trajectory(t) for t in ends])
        for c, name in enumerate(("pitch", "yaw", "depth", "roll", "jaw")):
            actuator = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, f"{tool}_{name}")
            unit, tolerance = (1.0, rec.TOLERANCE["m"]) if name == "depth" else (np.degrees(1.0), rec.TOLERANCE["deg"])
            np.testing.assert_allclose(played[:, c], recording.actions[:, actuator] * unit, rtol=0,
                                       atol=tolerance * (1 + 1e-9))
            checked += 1
    assert checked == 5


def bad(tmp_path, name: str, meta: dict | None = None, actions=None, raw: bytes | None = None):
    path = tmp_path / name
    if raw is not None:
        path.write_bytes(raw)
        return path
    arrays = {}
    if meta is not None:
        arrays["meta"] = np.frombuffer(json.dumps(meta).encode(), dtype=np.uint8)
    if actions is not None:
        arrays["actions"] = actions
    np.savez(path, **arrays)
    return path


def good_meta(**change) -> dict:
    meta = {"format": rec.FORMAT, "version": rec.VERSION, "task": "grasp_lift", "seed": 1, "policy": "idle",
            "control_timestep_s": 0.02, "time_limit_s": 1.0, "steps": 3, "success": False,
            "final_state_sha256": "0" * 64}
    meta.update(change)
    return meta


def test_bad_recordings_are_refused_in_one_line(tmp_path):
    good = rec.record("grasp_lift", seed=1, policy="idle", time_limit_s=0.2)
    good.save(tmp_path / "good.npz")
    whole = (tmp_path / "good.npz").read_bytes()
    five = np.zeros((3, 5))
    cases = {
        "missing": (tmp_path / "nothing.npz", "no such file"),
        "folder": (tmp_path, "a folder"),
        "text": (bad(tmp_path, "text.npz", raw=b"hello, not a zip\n"), "not an .npz"),
        "truncated": (bad(tmp_path, "cut.npz", raw=whole[: len(whole) // 2]), "truncated"),
        "foreign": (bad(tmp_path, "foreign.npz", actions=five), "no 'meta'"),
        "other format": (bad(tmp_path, "other.npz", good_meta(format="lerobot"), five), "not a viscera recording"),
        "newer": (bad(tmp_path, "newer.npz", good_meta(version=rec.VERSION + 1), five), "newer"),
        "task": (bad(tmp_path, "task.npz", good_meta(task="appendectomy"), five), "unknown task"),
        "seed": (bad(tmp_path, "seed.npz", good_meta(seed=-4), five), "seed"),
        "timestep": (bad(tmp_path, "dt.npz", good_meta(control_timestep_s=0), five), "control_timestep_s"),
        "no actions": (bad(tmp_path, "none.npz", good_meta()), "no 'actions'"),
        "nan": (bad(tmp_path, "nan.npz", good_meta(), np.full((3, 5), np.nan)), "NaN"),
        "steps": (bad(tmp_path, "steps.npz", good_meta(steps=9), five), "9 steps"),
        "shape": (bad(tmp_path, "shape.npz", good_meta(), np.zeros(3)), "2-D"),
        "key": (bad(tmp_path, "key.npz", {k: v for k, v in good_meta().items() if k != "policy"}, five), "'policy'"),
        "no digest": (bad(tmp_path, "nodigest.npz", {k: v for k, v in good_meta().items()
                                                       if k != "final_state_sha256"}, five), "'final_state_sha256'"),
        "digest": (bad(tmp_path, "digest.npz", good_meta(final_state_sha256="abc"), five), "64 hex digits"),
        "success": (bad(tmp_path, "success.npz", good_meta(success="yes"), five), "true or false"),
        "width": (bad(tmp_path, "width.npz", good_meta(), np.zeros((3, 9))), "takes 5"),  # clear_area's actions
    }
    garbled = tmp_path / "garbled.npz"
    np.savez(garbled, meta=np.frombuffer(b"{not json", dtype=np.uint8), actions=five)
    cases["meta not JSON"] = (garbled, "not JSON")
    # a flipped byte inside the compressed actions: the stream breaks, or the zip's CRC catches it
    for offset in (40, 100):
        corrupt = bytearray(whole)
        corrupt[whole.index(b"actions.npy") + offset] ^= 0xFF
        cases[f"flip {offset}"] = (bad(tmp_path, f"flip{offset}.npz", raw=bytes(corrupt)), "corrupt")
    for case, (path, words) in cases.items():
        with pytest.raises(rec.RecordingError) as error:
            rec.load(path)
        message = str(error.value)
        assert words in message and "\n" not in message, (case, message)
    with zipfile.ZipFile(tmp_path / "good.npz") as archive:
        assert set(archive.namelist()) == {"meta.npy", "actions.npy"}


def test_actions_of_another_task_are_refused_before_stepping(tmp_path):
    recording = rec.record("grasp_lift", seed=1, policy="idle", time_limit_s=0.1)
    foreign = rec.Recording(**{**recording.__dict__, "task": "clear_area"})
    with pytest.raises(rec.RecordingError, match="takes 9"):
        rec.replay(foreign)


def test_record_and_replay_commands_agree_and_end_with_the_verdict(tmp_path):
    """`record` prints and stores the final state's digest; `replay --json` writes the same beside
    the score; both end with the verdict line; --trajectory writes a file per tool."""
    import subprocess
    import sys
    out = tmp_path / "episode.npz"
    recorded = subprocess.run([sys.executable, "-m", "viscera", "record", "clear_area", "--seed", "1003", "--policy",
                               "random", "--out", str(out), "--time-limit", "1", "--quiet"],
                              capture_output=True, text=True, timeout=300)
    assert recorded.returncode == 0, recorded.stderr
    lines = recorded.stdout.strip().splitlines()
    assert lines[-1].startswith("success: no (clear_area: ")
    digest = next(line.split()[-1] for line in lines if line.startswith("final state"))
    assert rec.load(out).final_state_sha256 == digest
    score_file, trajectory = tmp_path / "score.json", tmp_path / "motion.json"
    replayed = subprocess.run([sys.executable, "-m", "viscera", "replay", str(out), "--json", str(score_file),
                               "--trajectory", str(trajectory), "--quiet"], capture_output=True, text=True, timeout=300)
    assert replayed.returncode == 0, replayed.stderr
    assert replayed.stdout.strip().splitlines()[-1] == lines[-1]
    score = json.loads(score_file.read_text())
    assert score["final_state_sha256"] == digest and score["success"] is False
    assert set(score["tools"]) == {"grasper", "retractor"} and "tissue" in score
    for tool in ("grasper", "retractor"):
        assert ToolTrajectory.from_file(str(tmp_path / f"motion_{tool}.json")).duration == pytest.approx(1.0)


def test_the_replay_command_refuses_a_bad_recording_in_one_line(tmp_path):
    """A file that is not a recording, and one whose replay ends elsewhere than recorded: one
    stderr line each naming the file and what is wrong, status 1, before or instead of a score."""
    import subprocess
    import sys
    good = rec.record("grasp_lift", seed=2, policy="random", time_limit_s=0.2)
    good.save(tmp_path / "good.npz")
    whole = (tmp_path / "good.npz").read_bytes()
    other = rec.Recording(**{**good.__dict__, "final_state_sha256": "f" * 64})  # as if recorded on another build
    other.save(tmp_path / "other.npz")
    cases = {
        bad(tmp_path, "cut.npz", raw=whole[:-30]): "truncated",
        bad(tmp_path, "text.npz", raw=b"hello\n"): "not an .npz",
        bad(tmp_path, "newer.npz", good_meta(version=rec.VERSION + 1), np.zeros((3, 5))): "newer",
        tmp_path / "other.npz": "the replay ended in another state",
    }
    for path, words in cases.items():
        result = subprocess.run([sys.executable, "-m", "viscera", "replay", str(path), "--quiet"],
                                capture_output=True, text=True, timeout=300)
        lines = result.stderr.splitlines()
        assert result.returncode == 1 and len(lines) == 1, (path, result.stderr)
        assert lines[0].startswith("python -m viscera replay: error: ") and str(path) in lines[0], lines[0]
        assert words in lines[0], lines[0]
        assert "success:" not in result.stdout  # no verdict for what was not replayed


def test_a_saved_recording_is_readable_by_others(tmp_path):
    """Written through a private temporary file, the recording still gets the umask's mode."""
    import os
    rec.record("grasp_lift", seed=1, policy="idle", time_limit_s=0.04).save(tmp_path / "a.npz")
    mask = os.umask(0o022)
    os.umask(mask)
    assert (tmp_path / "a.npz").stat().st_mode & 0o777 == 0o666 & ~mask
    assert [p.name for p in tmp_path.iterdir()] == ["a.npz"]  # no temporary left behind


def test_replay_shows_the_episode_in_meshcat(tmp_path):
    """--viewer meshcat serves the replay on loopback, then gives the same lines as without it."""
    import subprocess
    import sys
    rec.record("grasp_lift", seed=1, policy="random", time_limit_s=0.2).save(tmp_path / "a.npz")
    result = subprocess.run([sys.executable, "-m", "viscera", "replay", str(tmp_path / "a.npz"), "--viewer", "meshcat"],
                            capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert lines[0].startswith("meshcat viewer: http://127.0.0.1:")
    assert "bit-identical" in result.stdout and lines[-1].startswith("success: no (grasp_lift: ")
