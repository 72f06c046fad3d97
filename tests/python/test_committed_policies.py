"""The committed learned policies (docs/learning/policies, written by python/tools/learning/bc.py,
and the residual RL policy by rl_grasp_lift.py) reproduce what docs/learning/bc.json and
docs/learning/rl_grasp_lift.json say of them, through the command line a user runs:
`python -m viscera play TASK --seed S --policy FILE` exits 0 on a seed the evaluation counted a
success and 1 on one it counted a failure. The short version of the evaluation: one seed of each
verdict per policy (no training here)."""

from __future__ import annotations

import json
import pathlib
import subprocess
import sys

import pytest

from viscera import policy_file

ROOT = pathlib.Path(__file__).resolve().parents[2]
RECORD = json.loads((ROOT / "docs" / "learning" / "bc.json").read_text())
ENTRIES = [(task, kind, entry) for task, kinds in sorted(RECORD["results"].items())
           for kind, entry in sorted(kinds.items())]
RL = json.loads((ROOT / "docs" / "learning" / "rl_grasp_lift.json").read_text())
if "policy_file" in RL:  # the residual RL policy: its final evaluation is the same kind of entry
    ENTRIES.append((RL["task"], "rl", dict(RL["final"], policy_file=RL["policy_file"],
                                           eval_seeds=RL["final_seeds"])))
# a failed episode runs to the time limit: checked where that is short (grasp_lift's 15 s)
FAILURE_CHECKED = ("grasp_lift",)


def play(task: str, seed: int, path: pathlib.Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "viscera", "play", task, "--seed", str(seed), "--policy", str(path)],
                          capture_output=True, text=True, timeout=600, cwd=ROOT)


def test_every_task_has_a_committed_state_policy():
    assert sorted(RECORD["results"]) == ["clear_area", "grasp_lift", "retract_reach", "run_the_bowel"]
    for task, kinds in RECORD["results"].items():
        assert "state" in kinds, task


@pytest.mark.parametrize("task, kind, entry", ENTRIES, ids=[f"{t}_{k}" for t, k, _ in ENTRIES])
def test_the_committed_policy_is_the_file_the_record_describes(task, kind, entry):
    path = ROOT / entry["policy_file"]
    assert path == ROOT / "docs" / "learning" / "policies" / f"{task}_{kind}.npz"
    policy = policy_file.load(path)
    assert policy.task == task and (policy.pixels is not None) == (kind == "pixels")
    first, last = entry["eval_seeds"]
    assert (first, last) == tuple(RECORD["eval_seeds"]) and entry["episodes"] == last - first + 1
    assert entry["success_rate"] == pytest.approx(len(entry["succeeded_seeds"]) / entry["episodes"])
    if kind == "rl":  # a residual on a cloned policy (held in the file), its demonstrations before these seeds
        assert policy.sha256 == RL["policy_sha256"] and path.stat().st_size == RL["policy_bytes"]
        assert policy.meta["architecture"]["residual"]["scale"] == RL["start"]["residual_scale"]
        assert RL["base_demonstration_seeds"][1] < first
        return
    assert path.stat().st_size == entry["policy_bytes"]
    assert entry["demonstration_seeds"][1] < first  # no demonstration on an evaluation seed


@pytest.mark.parametrize("task, kind, entry", ENTRIES, ids=[f"{t}_{k}" for t, k, _ in ENTRIES])
def test_play_reproduces_the_evaluations_verdicts(task, kind, entry):
    path = ROOT / entry["policy_file"]
    first, last = entry["eval_seeds"]
    succeeded = entry["succeeded_seeds"]
    failed = [seed for seed in range(first, last + 1) if seed not in succeeded]
    if succeeded:
        played = play(task, succeeded[0], path)
        assert played.returncode == 0, (succeeded[0], played.stdout[-2000:], played.stderr[-2000:])
        assert played.stdout.splitlines()[-1].startswith("success: yes"), played.stdout[-500:]
    if failed and task in FAILURE_CHECKED:
        played = play(task, failed[0], path)
        assert played.returncode == 1, (failed[0], played.stdout[-2000:], played.stderr[-2000:])
