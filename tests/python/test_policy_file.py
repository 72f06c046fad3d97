"""Policy files (viscera.policy_file): learned policies as files anyone can play. Small policies
with random weights are written through the writer (no training here), played, recorded and
collected through the command line; a bad or foreign file is one line before any simulation;
inference is bit-identical after a save and load and with NumPy's AVX-512 and AVX2 code off; a
chunked policy's temporal ensembling is the hand computation."""

from __future__ import annotations

import copy
import functools
import json
import math
import os
import pathlib
import subprocess
import sys

import numpy as np
import pytest

import viscera.tasks
from viscera import policy_file, recording

ROOT = pathlib.Path(__file__).resolve().parents[2]
TASK = "grasp_lift"
LINES = ["episode", "score", "grasper", "camera", "tissue", "wall", "success:"]  # what play prints for grasp_lift, in order


def viscera_command(*args, timeout=120) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "viscera", *map(str, args)], capture_output=True, text=True,
                          timeout=timeout, cwd=ROOT)


def run_main(capsys, *argv) -> tuple[int, list[str], list[str]]:
    """The command line in this process: its status, stdout lines and stderr lines."""
    from viscera.__main__ import main
    try:
        status = main([str(a) for a in argv])
    except SystemExit as stopped:
        status = stopped.code
    captured = capsys.readouterr()
    return status, captured.out.splitlines(), captured.err.splitlines()


@functools.cache
def fields(task: str = TASK, pixels: bool = False) -> dict:
    """save()'s environment fields for `task` (the state entries a pixel policy reads: its joints)."""
    env = viscera.tasks.load(task, seed=0, pixels=pixels)
    try:
        return policy_file.describe(env, state=["tool_joints"] if pixels else None, pixels=pixels)
    finally:
        viscera.tasks.close(env)


def random_policy(path, task=TASK, pixels=False, chunk=1, target="change", m=0.1, seed=0, hidden=16,
                  float32=False, pooling="flatten") -> policy_file.LearnedPolicy:
    """A small policy of `task` with random weights: the state (normalised), the clock and the
    previous command (and a two-layer conv encoder on the RGB with `pixels`, its maps flattened or
    a spatial softmax's keypoints, `pooling`), `chunk` actions."""
    rng = np.random.default_rng(seed)
    described = copy.deepcopy(fields(task, pixels))
    state = sum(size for _, size in described["observation"]["state"])
    actions = described["action"]["size"]
    weights = {"state.mean": rng.normal(size=state) * 0.01, "state.scale": rng.uniform(0.5, 2.0, state)}
    architecture = {"kind": "mlp", "inputs": ["state", "clock", "previous_action"], "clock_steps": 750,
                    "state_normalisation": {"mean": "state.mean", "scale": "state.scale"}, "layers": [],
                    "output": {"target": target, "scale": "output.scale", "chunk": chunk}}
    if target == "change":
        architecture["output"]["absolute"] = [actions - 1]  # the jaw's command itself, as bc.py does
    if chunk > 1:
        architecture["output"]["temporal_ensemble_m"] = m
    features = 0
    if pixels:
        architecture["inputs"].insert(0, "pixels")
        architecture["pixel_encoder"] = {"scale": 255.0, "layers": [
            {"kind": "conv2d", "weight": "conv0.weight", "bias": "conv0.bias", "stride": 4, "activation": "relu"},
            {"kind": "conv2d", "weight": "conv1.weight", "bias": "conv1.bias", "stride": 2,
             "activation": "relu" if pooling == "flatten" else "none"}], "pooling": pooling}
        # spatial softmax: maps of a few units' spread, so that the keypoints depend on the image
        spread = 0.1 if pooling == "flatten" else 2.0
        weights.update({"conv0.weight": rng.normal(size=(6, 3, 8, 8)) * 0.1, "conv0.bias": rng.normal(size=6) * 0.1,
                        "conv1.weight": rng.normal(size=(4, 6, 4, 4)) * spread, "conv1.bias": rng.normal(size=4) * 0.1})
        height = described["observation"]["pixels"]["height"]
        size = ((height - 8) // 4 + 1 - 4) // 2 + 1
        features = 4 * size * size if pooling == "flatten" else 2 * 4
    width = features + state + 1 + actions
    for i, (inputs, outputs, activation) in enumerate([(width, hidden, "relu"), (hidden, chunk * actions, "none")]):
        weights[f"layer{i}.weight"] = rng.normal(size=(outputs, inputs)) / np.sqrt(inputs)
        weights[f"layer{i}.bias"] = rng.normal(size=outputs) * 0.1
        architecture["layers"].append({"kind": "dense", "weight": f"layer{i}.weight", "bias": f"layer{i}.bias",
                                       "activation": activation})
    weights["output.scale"] = np.full(actions, 0.05)
    if float32:
        weights = {k: v.astype(np.float32) for k, v in weights.items()}
    return policy_file.save(path, weights=weights, architecture=architecture,
                            training={"by": "test_policy_file", "seed": seed}, **described)


def inputs(policy, steps: int, seed: int = 1):
    """Random state vectors (and RGB images) a policy reads."""
    rng = np.random.default_rng(seed)
    size = sum(n for _, n in policy.state_entries)
    shape = None if policy.pixels is None else (policy.pixels["height"], policy.pixels["width"], 3)
    return [(rng.normal(size=size), None if shape is None else rng.integers(0, 256, shape, dtype=np.uint8))
            for _ in range(steps)]


def episode(policy, steps: int = 6) -> np.ndarray:
    policy.reset()
    return np.array([policy.act(state, pixels) for state, pixels in inputs(policy, steps)])


# --- played through the command line


def test_play_record_and_replay_with_policy_files(tmp_path, capsys):
    """A state policy plays (exit 1: it does not succeed; the lines the scripted policy prints,
    the episode naming file:NAME#SHA); a pixel policy with action chunks records (its environment
    loaded with pixels) and the recording names it and replays bit for bit without it."""
    state = random_policy(tmp_path / "state.npz")
    played = viscera_command("play", TASK, "--seed", 3, "--policy", state.path, "--time-limit", 0.4, "--quiet")
    assert played.returncode == 1, played.stderr
    lines = played.stdout.splitlines()
    assert [line.split()[0] for line in lines] == LINES
    assert f"{TASK}, seed 3, file:state.npz#{state.sha256[:12]} policy, 20 ticks of 20 ms" in lines[0]
    assert lines[-1].startswith(f"success: no ({TASK}: ")
    status, idle, _ = run_main(capsys, "play", TASK, "--seed", 3, "--policy", "idle", "--time-limit", 0.4, "--quiet")
    assert status == 1 and [line.split()[0] for line in idle] == LINES  # the scripted kinds' lines, the same

    pixels = random_policy(tmp_path / "pixels.npz", pixels=True, chunk=4)
    out = tmp_path / "episode.npz"
    recorded = viscera_command("record", TASK, "--seed", 4, "--policy", pixels.path, "--out", out,
                               "--time-limit", 0.3, "--quiet")
    assert recorded.returncode == 0, recorded.stderr
    made = recording.load(out)
    assert made.policy == f"file:pixels.npz#{pixels.sha256[:12]}" == pixels.label and made.steps == 15
    with np.load(out) as archive:
        assert json.loads(archive["meta"].tobytes())["policy"] == pixels.label
    digest = recorded.stdout.splitlines()[-2].split()[-1]
    os.unlink(pixels.path)  # a replay needs no policy: it steps the stored actions
    replayed = viscera_command("replay", out, "--quiet")
    assert replayed.returncode == 0, replayed.stderr
    assert "bit-identical" in replayed.stdout and digest == made.final_state_sha256
    assert replayed.stdout.splitlines()[-1] == recorded.stdout.splitlines()[-1]


def test_a_policy_file_that_succeeds_exits_0(tmp_path, capsys):
    """A ReLU network of the clock alone that interpolates a scripted episode's commands (knots at
    every tick) plays it back open loop and succeeds: status 0, the verdict yes."""
    scripted = recording.record(TASK, seed=2, policy="scripted")
    assert scripted.success
    commands, (ticks, actions) = scripted.actions, scripted.actions.shape
    slopes = np.diff(commands, axis=0) * ticks  # per unit of the clock, ticks / ticks
    bends = np.diff(np.vstack([np.zeros((1, actions)), slopes]), axis=0)
    described = copy.deepcopy(fields())
    described["observation"]["state"] = []
    described["action"]["normalisation"] = "none"  # the network gives rad and m
    policy = policy_file.save(
        tmp_path / "open_loop.npz", **described,
        weights={"knots.weight": np.ones((ticks - 1, 1)), "knots.bias": -np.arange(ticks - 1) / ticks,
                 "out.weight": bends.T, "out.bias": commands[0]},
        architecture={"kind": "mlp", "inputs": ["clock"], "clock_steps": ticks, "output": {"target": "action"},
                      "layers": [{"kind": "dense", "weight": "knots.weight", "bias": "knots.bias", "activation": "relu"},
                                 {"kind": "dense", "weight": "out.weight", "bias": "out.bias", "activation": "none"}]})
    status, lines, errors = run_main(capsys, "play", TASK, "--seed", 2, "--policy", policy.path, "--quiet")
    assert status == 0, errors
    assert lines[-1].startswith(f"success: yes ({TASK}: ") and "file:open_loop.npz#" in lines[0]
    again = recording.record(TASK, seed=2, policy=policy.path)
    np.testing.assert_allclose(again.actions, commands[:len(again.actions)], rtol=0, atol=1e-12)


# --- bad and foreign files: one line, before any simulation


def write_raw(path, meta, arrays) -> pathlib.Path:
    """A file as a writer other than ours could make it (no checks)."""
    np.savez(path, meta=np.frombuffer(json.dumps(meta).encode(), np.uint8), **arrays)
    return pathlib.Path(path)


def bad_files(tmp_path) -> dict:
    good = random_policy(tmp_path / "good.npz")
    data = pathlib.Path(good.path).read_bytes()
    meta, weights = good.meta, good.weights

    def changed(name, change=None, arrays=None):
        edited = copy.deepcopy(meta)
        if change:
            change(edited)
        return write_raw(tmp_path / name, edited, arrays if arrays is not None else weights)

    def setter(*keys, value):
        def change(m):
            for key in keys[:-1]:
                m = m[key]
            m[keys[-1]] = value
        return change

    (tmp_path / "folder.npz").mkdir()
    (tmp_path / "text.npz").write_text("weights\n")
    (tmp_path / "cut.npz").write_bytes(data[:len(data) // 2])
    middle = len(data) // 2  # a flipped byte inside an array: the zip's CRC check fails
    (tmp_path / "flipped.npz").write_bytes(data[:middle] + bytes([data[middle] ^ 0xFF]) + data[middle + 1:])
    recording.record(TASK, seed=1, policy="idle", time_limit_s=0.04).save(tmp_path / "recording.npz")
    def half_axis(m):
        next(entry for entry in m["observation"]["state"] if entry[0] == "intestine_axis")[1] = 150

    def four_actions(m):
        m["action"].update({key: m["action"][key][:4] for key in ("names", "low", "high")}, size=4)
        m["architecture"]["output"]["absolute"] = []
    return {
        tmp_path / "missing.npz": "no such file",
        tmp_path / "folder.npz": "a folder",
        tmp_path / "text.npz": "not an .npz file",
        tmp_path / "cut.npz": "truncated",
        tmp_path / "flipped.npz": "corrupt or truncated",
        tmp_path / "recording.npz": "a viscera recording, not a policy",
        changed("format.npz", setter("format", value="other")): "not a viscera policy",
        changed("newer.npz", setter("version", value=2)): "newer than this viscera reads",
        changed("task.npz", setter("task", value="clear_area")): "a policy for clear_area, not grasp_lift",
        changed("scene.npz", setter("scene", value="anatomical")): "not abdomen (--scene anatomical)",
        changed("kind.npz", setter("architecture", "kind", value="transformer")): "architecture.kind \"transformer\"",
        changed("key.npz", setter("architecture", "dropout", value=0.1)): "'dropout', which this viscera does not know",
        changed("nan.npz", arrays={**weights, "layer0.bias": np.full(16, np.nan)}): "'layer0.bias' holds NaN",
        changed("shape.npz", arrays={**weights, "layer1.weight": np.zeros((5, 17))}): "is (5, 17), it must be (any, 16)",
        changed("unused.npz", arrays={**weights, "extra": np.zeros(3)}): "'extra', which its architecture does not use",
        changed("dtype.npz", arrays={**weights, "layer0.bias": np.zeros(16, np.int64)}): "not float32 or float64",
        changed("layout.npz", half_axis,
                {**weights, "state.mean": np.zeros(len(weights["state.mean"]) - 150),
                 "state.scale": np.ones(len(weights["state.mean"]) - 150),
                 "layer0.weight": np.zeros((16, weights["layer0.weight"].shape[1] - 150))}):
            "'intestine_axis' as 150 values, grasp_lift's has 300: another observation layout",
        changed("entry.npz", lambda m: m["observation"]["state"].__setitem__(-1, ["target_coverage", 2])):
            "reads the observation 'target_coverage', which grasp_lift's observation has not",
        changed("size.npz", four_actions, {**weights, "layer1.weight": weights["layer1.weight"][:4], "layer1.bias": weights["layer1.bias"][:4],
                 "output.scale": weights["output.scale"][:4],
                 "layer0.weight": weights["layer0.weight"][:, :-1]}): "gives actions of 4 values, grasp_lift takes 5",
        changed("range.npz", setter("action", "high", value=[2.0] * 5)): "another action normalisation",
        changed("clip.npz", setter("architecture", "state_normalisation", "clip", value=-1.0)):
            "state_normalisation.clip",
        changed("residual.npz", setter("architecture", "residual", value={
            "inputs": ["base_action"], "scale": 0.1,
            "layers": [{"kind": "dense", "weight": "layer1.weight", "bias": "layer1.bias", "activation": "none"}]})):
            "residual.layers[0].weight: array 'layer1.weight' is (5, 16), it must be (any, 5)",
        changed("held.npz", setter("architecture", "output", "held", value={"indices": [3, 3], "values": [0.0, 0.1]})):
            "output.held must give distinct action indices (0 to 4) and as many values",
    }


def forbid_simulation(monkeypatch):
    """Environments that cannot be reset or stepped: a check that comes after it fails the test."""
    built = recording.load_task

    def load_task(*args, **kwargs):
        env = built(*args, **kwargs)

        def refuse(*_):
            raise AssertionError("the environment was reset or stepped before the policy file was refused")
        env.reset = env.step = refuse
        return env

    monkeypatch.setattr(recording, "load_task", load_task)


def test_bad_policy_files_are_one_line_before_any_simulation(tmp_path, capsys, monkeypatch):
    cases = bad_files(tmp_path)
    forbid_simulation(monkeypatch)
    for path, words in cases.items():
        status, out, errors = run_main(capsys, "play", TASK, "--policy", path, "--quiet")
        assert status == 2 and out == [] and len(errors) == 1, (path, out, errors)
        assert errors[0].startswith(f"python -m viscera play: error: --policy {path}: "), errors[0]
        assert words in errors[0], (words, errors[0])


def test_bad_policy_files_through_every_command(tmp_path):
    """record and dataset say it in one line too, in a process of their own (no traceback), and
    write nothing; a pixel policy's dataset needs its pixels."""
    truncated = tmp_path / "cut.npz"
    truncated.write_bytes(pathlib.Path(random_policy(tmp_path / "good.npz").path).read_bytes()[:1000])
    out = tmp_path / "out.npz"
    result = viscera_command("record", TASK, "--seed", 1, "--policy", truncated, "--out", out, "--quiet")
    assert result.returncode == 2 and result.stdout == "" and not out.exists()
    assert result.stderr.splitlines() == [f"python -m viscera record: error: --policy {truncated}: truncated (the "
                                          ".npz file ends before its zip directory)"]
    result = viscera_command("dataset", TASK, "--policy", truncated, "--format", "minari", "--out", tmp_path / "d")
    assert result.returncode == 2 and not (tmp_path / "d").exists()
    assert result.stderr.splitlines() == [f"python -m viscera dataset: error: --policy '{truncated}': truncated "
                                          "(the .npz file ends before its zip directory)"]
    pixels = random_policy(tmp_path / "pixels.npz", pixels=True)
    result = viscera_command("dataset", TASK, "--policy", pixels.path, "--format", "minari", "--out", tmp_path / "d")
    assert result.returncode == 2 and len(result.stderr.splitlines()) == 1
    assert "pixels.npz': reads the laparoscope camera's 84x84 RGB: collect with --pixels --size 84x84" in result.stderr
    result = viscera_command("record", TASK, "--seed", 1, "--policy", pixels.path, "--out", pixels.path)
    assert result.returncode == 2 and "that is the policy file" in result.stderr
    assert policy_file.load(pixels.path).sha256 == pixels.sha256  # not overwritten


def test_the_writer_refuses_what_the_loader_would(tmp_path):
    with pytest.raises(policy_file.PolicyFileError, match=r"no\.npz: array 'layer0\.bias' holds NaN"):
        described = copy.deepcopy(fields())
        described["observation"]["state"] = []
        policy_file.save(tmp_path / "no.npz", **described, weights={
            "layer0.weight": np.zeros((5, 1)), "layer0.bias": np.array([0, 0, np.nan, 0, 0])},
            architecture={"kind": "mlp", "inputs": ["clock"], "clock_steps": 10, "output": {"target": "action"},
                          "layers": [{"kind": "dense", "weight": "layer0.weight", "bias": "layer0.bias",
                                      "activation": "none"}]})
    assert not (tmp_path / "no.npz").exists() and list(tmp_path.iterdir()) == []


# --- inference


def test_save_and_load_round_trip_bit_for_bit(tmp_path):
    """Weights keep their bits and dtype (float32 stays float32); the loaded policy written again
    acts bit for bit as the first; a reset starts the same episode over."""
    first = random_policy(tmp_path / "a.npz", pixels=True, chunk=3, float32=True)
    assert all(w.dtype == np.float32 for w in first.weights.values())
    second = policy_file.save(tmp_path / "b.npz", weights=first.weights, **first.fields)
    for name, weight in first.weights.items():
        assert second.weights[name].dtype == weight.dtype and second.weights[name].tobytes() == weight.tobytes()
    assert second.fields == first.fields
    actions = episode(first)
    assert actions.tobytes() == episode(second).tobytes() == episode(first).tobytes()
    assert np.all(np.abs(actions) <= 1.0) and np.ptp(actions, axis=0).max() > 0


def spatial_softmax(torch, maps):
    """Levine et al.'s keypoints, from torch's softmax: (1, C, H, W) -> (2 C,), per channel the
    expected column, then row, each -1 to 1 across the map."""
    _, channels, height, width = maps.shape
    weights = torch.softmax(maps.reshape(channels, height * width), dim=-1)
    columns = torch.linspace(-1.0, 1.0, width, dtype=torch.float64).repeat(height)
    rows = torch.linspace(-1.0, 1.0, height, dtype=torch.float64).repeat_interleave(width)
    return torch.stack([(weights * columns).sum(-1), (weights * rows).sum(-1)], dim=-1).reshape(-1)


@pytest.mark.parametrize("pooling", ["flatten", "spatial_softmax"])
def test_the_network_is_torchs(tmp_path, pooling):
    """The convolutions, flattening (or spatial softmax) and layers compute what torch's Conv2d,
    Flatten (or softmax and expectations) and Linear do with the same weights (float64): a
    trainer's torch module ports as it is."""
    torch = pytest.importorskip("torch")
    policy = random_policy(tmp_path / "p.npz", pixels=True, pooling=pooling)
    w = {k: torch.as_tensor(v) for k, v in policy.weights.items()}
    state, image = inputs(policy, 1)[0]
    clock, previous = 0.25, np.linspace(-0.5, 0.5, policy.action_size)
    with torch.no_grad():
        x = torch.as_tensor(image, dtype=torch.float64).permute(2, 0, 1)[None] / 255.0
        x = torch.relu(torch.nn.functional.conv2d(x, w["conv0.weight"], w["conv0.bias"], stride=4))
        x = torch.nn.functional.conv2d(x, w["conv1.weight"], w["conv1.bias"], stride=2)
        if pooling == "flatten":
            features = torch.relu(x).flatten(1)[0]
        else:
            features = spatial_softmax(torch, x)
            assert features.std() > 0.05  # the keypoints are spread: they test something
        normalised = (torch.as_tensor(state) - w["state.mean"]) / w["state.scale"]
        x = torch.cat([features, normalised, torch.tensor([clock], dtype=torch.float64), torch.as_tensor(previous)])
        x = torch.relu(torch.nn.functional.linear(x, w["layer0.weight"], w["layer0.bias"]))
        expected = torch.nn.functional.linear(x, w["layer1.weight"], w["layer1.bias"]).numpy()
    np.testing.assert_allclose(policy.network(state, clock, previous, image)[0], expected, rtol=1e-12, atol=1e-12)


def toy(tmp_path, name, chunk, m, target, weight, bias, absolute=()):
    """A policy of the clock (and its previous command): one dense layer, 2 actions in wide ranges."""
    inputs_ = ["clock"] + (["previous_action"] if target == "change" else [])
    output = {"target": target, "chunk": chunk}
    if chunk > 1:
        output["temporal_ensemble_m"] = m
    if absolute:
        output["absolute"] = list(absolute)
    return policy_file.save(
        tmp_path / name, task=TASK, scene="abdomen", control_timestep_s=0.02,
        observation={"state": [], "pixels": None},
        action={"size": 2, "names": ["a", "b"], "low": [-100.0, -100.0], "high": [100.0, 100.0], "normalisation": "none"},
        architecture={"kind": "mlp", "inputs": inputs_, "clock_steps": 10, "output": output,
                      "layers": [{"kind": "dense", "weight": "w", "bias": "b", "activation": "none"}]},
        weights={"w": np.pad(weight, ((0, 0), (0, 2 if target == "change" else 0))), "b": bias})


def test_temporal_ensembling_is_the_hand_computation(tmp_path):
    """Chunks of 3 commands that are affine in the clock: the command at step t is the average of
    the chunks made at t - 2, t - 1 and t (those there are) for step t, weighted exp(-m * age);
    m = -k is ACT's own weighting (oldest first, exp(-k * i)); a chunk of 1 with target 'change'
    is bc.py's rule."""
    K, m = 3, 0.5
    slope, offset = np.arange(1.0, 7.0)[:, None], np.arange(6.0) * 10.0  # chunk row j, action a: 2 j + a
    policy = toy(tmp_path, "chunk.npz", K, m, "action", slope, offset)

    def predicted(made, age):  # what the chunk made at step `made` says for step made + age
        return offset.reshape(K, 2)[age] + slope[:, 0].reshape(K, 2)[age] * made / 10

    policy.reset()
    for t in range(6):
        ages = range(min(t, K - 1) + 1)
        weights = [math.exp(-m * age) for age in ages]
        expected = sum(w * predicted(t - age, age) for w, age in zip(weights, ages)) / sum(weights)
        np.testing.assert_allclose(policy.act(None), expected, rtol=1e-15, atol=0)

    k = 0.01  # ACT's code: actions_for_curr_step oldest first, exp_weights = exp(-k * arange(n)), normalised
    act = toy(tmp_path, "act.npz", K, -k, "action", slope, offset)
    act.reset()
    for t in range(6):
        made = sorted(t - age for age in range(min(t, K - 1) + 1))  # oldest first
        weights = np.exp(-k * np.arange(len(made)))
        expected = sum(w / weights.sum() * predicted(s, t - s) for w, s in zip(weights, made))
        np.testing.assert_allclose(act.act(None), expected, rtol=1e-14, atol=0)

    # one command, the change from the previous one (the second action absolute): bc.py's rule
    change = toy(tmp_path, "change.npz", 1, None, "change", np.array([[1.0], [2.0]]), np.array([0.5, -0.25]),
                 absolute=[1])
    change.reset()
    previous = np.zeros(2)
    for t in range(4):
        output = np.array([1.0, 2.0]) * (t / 10) + np.array([0.5, -0.25])
        previous = np.clip(np.where([False, True], output, previous + output), -100, 100)
        assert change.act(None).tobytes() == previous.tobytes()


def test_clipped_inputs_and_held_actions(tmp_path):
    """state_normalisation.clip bounds each normalised entry: a state far outside the training's
    acts as one at the bound; output.held commands its actuators at the value given, whatever the
    network says (bc.py: an actuator no demonstration moved)."""
    plain = random_policy(tmp_path / "plain.npz", hidden=32)
    meta = copy.deepcopy(plain.meta)
    meta["architecture"]["state_normalisation"]["clip"] = 5.0
    meta["architecture"]["output"]["held"] = {"indices": [3], "values": [0.25]}
    clipped = policy_file.save(tmp_path / "clipped.npz", weights=plain.weights, architecture=meta["architecture"],
                               training=meta["training"], **fields())
    state = inputs(plain, 1)[0][0]
    mean, scale = plain.weights["state.mean"], plain.weights["state.scale"]
    far = state.copy()
    far[:20] = mean[:20] + 1e3 * scale[:20]           # a thousand scales out ...
    bound = state.copy()
    bound[:20] = mean[:20] + 5.0 * scale[:20]         # ... reads as five
    results = []
    for policy, given in ((clipped, far), (clipped, bound), (plain, far), (plain, bound)):
        policy.reset()
        results.append(policy.act(given))
    assert np.array_equal(results[0], results[1])
    assert not np.array_equal(results[2], results[3])  # unclipped, the two differ
    assert np.all(episode(clipped)[:, 3] == 0.25)
    assert len(set(episode(plain)[:, 3])) > 1


def with_residual(tmp_path, base, scale=0.1, hidden=8, seed=3):
    """`base` with a random residual correction over the state, the clock and the base's command."""
    rng = np.random.default_rng(seed)
    meta = copy.deepcopy(base.meta)
    state = sum(n for _, n in base.state_entries)
    width = state + 1 + base.action_size
    weights = {**base.weights, "res0.weight": rng.normal(size=(hidden, width)) / np.sqrt(width),
               "res0.bias": rng.normal(size=hidden) * 0.1,
               "res1.weight": rng.normal(size=(base.action_size, hidden)) * 2.0 / np.sqrt(hidden),
               "res1.bias": rng.normal(size=base.action_size) * 0.1}
    meta["architecture"]["residual"] = {"inputs": ["state", "clock", "base_action"], "scale": scale, "layers": [
        {"kind": "dense", "weight": "res0.weight", "bias": "res0.bias", "activation": "relu"},
        {"kind": "dense", "weight": "res1.weight", "bias": "res1.bias", "activation": "none"}]}
    return policy_file.save(tmp_path / "residual.npz", weights=weights, architecture=meta["architecture"],
                            training=meta["training"], **fields())


def test_a_residual_is_the_base_plus_its_scaled_correction(tmp_path):
    """architecture.residual (residual policy learning, rl_grasp_lift.py's): each command is the
    base network's, from its own memory of the commands executed, plus the scale times the
    correction network's output clipped to [-1, 1]; a held actuator stays held. Computed here by
    hand with matrix products, step by step beside the base alone."""
    plain = random_policy(tmp_path / "plain.npz", hidden=32, chunk=3)
    meta = copy.deepcopy(plain.meta)
    meta["architecture"]["output"]["held"] = {"indices": [3], "values": [0.25]}
    base = policy_file.save(tmp_path / "base.npz", weights=plain.weights, architecture=meta["architecture"],
                            training=meta["training"], **fields())
    residual = with_residual(tmp_path, base, scale=0.1)
    w = residual.weights
    mean, spread = w["state.mean"], w["state.scale"]
    base.reset()
    residual.reset()
    clipped = 0
    for step, (state, _) in enumerate(inputs(base, 8)):
        command = base.act(state)
        x = np.concatenate([(state - mean) / spread, [step / 750], command])
        correction = w["res1.weight"] @ np.maximum(w["res0.weight"] @ x + w["res0.bias"], 0.0) + w["res1.bias"]
        clipped += int(np.any(np.abs(correction) > 1.0))
        expected = np.clip(command + 0.1 * np.clip(correction, -1.0, 1.0), -1.0, 1.0)
        expected[3] = 0.25
        np.testing.assert_allclose(residual.act(state), expected, rtol=0, atol=1e-12)
        base.executed(expected)  # the base's next input is what was done
    assert clipped > 0  # the correction's clip was exercised
    assert not np.allclose(episode(residual), episode(base))


def test_a_policys_memory_is_what_it_gave_the_step_before(tmp_path):
    """architecture.memory: the last layer's values after the actions are the next step's input
    "memory", clipped, zeros at the first step and again after a reset (bc.py: the oracle's phase,
    lead tool and aims, carried by the policy). By hand with matrix products, step by step."""
    rng = np.random.default_rng(5)
    described = copy.deepcopy(fields())
    state = sum(size for _, size in described["observation"]["state"])
    actions, size, hidden = described["action"]["size"], 3, 16
    width = state + 1 + size
    weights = {"w0": rng.normal(size=(hidden, width)) / np.sqrt(width), "b0": rng.normal(size=hidden) * 0.1,
               "w1": rng.normal(size=(actions + size, hidden)) * 3.0 / np.sqrt(hidden),
               "b1": rng.normal(size=actions + size) * 0.1}
    architecture = {"kind": "mlp", "inputs": ["state", "clock", "memory"], "clock_steps": 750,
                    "memory": {"size": size, "clip": 2.0}, "output": {"target": "action"},
                    "layers": [{"kind": "dense", "weight": "w0", "bias": "b0", "activation": "relu"},
                               {"kind": "dense", "weight": "w1", "bias": "b1", "activation": "none"}]}
    policy = policy_file.save(tmp_path / "memory.npz", weights=weights, architecture=architecture, **described)
    states = [x for x, _ in inputs(policy, 6)]
    for _ in range(2):  # the second episode starts over from zeros
        policy.reset()
        memory, clipped = np.zeros(size), 0
        for step, x in enumerate(states):
            out = weights["w1"] @ np.maximum(weights["w0"] @ np.concatenate([x, [step / 750], memory])
                                             + weights["b0"], 0.0) + weights["b1"]
            np.testing.assert_allclose(policy.act(x), np.clip(out[:actions], -1.0, 1.0), rtol=0, atol=1e-12)
            clipped += int(np.any(np.abs(out[actions:]) > 2.0))
            memory = np.clip(out[actions:], -2.0, 2.0)
        assert clipped > 0
    bad = copy.deepcopy(architecture)
    bad["inputs"] = ["state", "clock"]
    with pytest.raises(policy_file.PolicyFileError, match="architecture.memory without 'memory' in the inputs"):
        policy_file.save(tmp_path / "bad.npz", weights=weights, architecture=bad, **described)


SIMD_CHILD = """
import sys, numpy as np
from numpy._core._multiarray_umath import __cpu_features__  # NumPy 2's
from viscera import policy_file
policy = policy_file.load(sys.argv[1])
with np.load(sys.argv[2]) as given:
    states, images = given["states"], given["images"]
policy.reset()
out = np.array([policy.act(s, i) for s, i in zip(states, images)])
np.save(sys.argv[3], out)
print(" ".join(k for k, on in __cpu_features__.items() if on))
"""


@pytest.mark.parametrize("pooling", ["flatten", "spatial_softmax"])
def test_inference_is_bit_identical_without_avx512_and_avx2(tmp_path, pooling):
    """The same file and inputs in a process where NumPy's AVX-512 and AVX2 code is disabled (and
    OpenBLAS told it is on a Haswell): the very same bits (the spatial softmax's exponentials
    included, which np.exp would not give)."""
    from numpy._core._multiarray_umath import __cpu_dispatch__, __cpu_features__
    disabled = [name for name in __cpu_dispatch__ if __cpu_features__.get(name)
                and (name.startswith("AVX512") or name == "AVX2")]
    policy = random_policy(tmp_path / "p.npz", pixels=True, chunk=3, hidden=64, pooling=pooling)
    given = inputs(policy, 5)
    np.savez(tmp_path / "inputs.npz", states=np.array([s for s, _ in given]), images=np.array([i for _, i in given]))
    here = episode(policy, 5)
    env = {**os.environ, "NPY_DISABLE_CPU_FEATURES": " ".join(disabled), "OPENBLAS_CORETYPE": "Haswell"}
    child = subprocess.run([sys.executable, "-c", SIMD_CHILD, policy.path, tmp_path / "inputs.npz", tmp_path / "out.npy"],
                           capture_output=True, text=True, env=env, timeout=120)
    assert child.returncode == 0, child.stderr
    assert not set(disabled) & set(child.stdout.split()), child.stdout  # they were off there
    assert np.load(tmp_path / "out.npy").tobytes() == here.tobytes()


# --- datasets


def test_a_dataset_of_a_policy_files_episodes(tmp_path):
    """Worker processes load the file from its path and act as it does here: the dataset's actions
    are the recorded episodes' commands, normalised."""
    pytest.importorskip("minari")
    from viscera import datasets
    from viscera.scale.gym_env import TaskEnv
    policy = random_policy(tmp_path / "p.npz")
    summary = datasets.write(TASK, tmp_path / "d", "minari", demonstrator=policy.path, seeds=range(7, 9), workers=2)
    assert summary["demonstrator"] == "policy" and summary["policy"] == policy.label and summary["episodes"] == 2
    env = TaskEnv(TASK)
    try:
        for seed, written in zip((7, 8), datasets.load(tmp_path / "d", "minari", TASK, "policy").iterate_episodes()):
            taken = recording.record(TASK, seed, policy.path)
            assert np.array_equal(written.actions, np.clip(env.gym_action(taken.actions), -1.0, 1.0))
    finally:
        env.close()


def test_the_spatial_softmaxs_exponential_is_libms_to_the_last_bits():
    """_exp_array (products and sums only, the same bits on any CPU) is e^x within 3e-16 relative
    over x <= 0, down to float64's smallest normal numbers, and 0 below where e^x underflows."""
    x = -np.concatenate([np.geomspace(1e-300, 700.0, 20_000), [0.0, np.log(2) / 2, 708.0, 746.0, 1e6]])
    exact = np.array([math.exp(v) for v in x])
    got = policy_file._exp_array(x)
    normal = exact >= np.finfo(float).tiny
    assert np.max(np.abs(got[normal] - exact[normal]) / exact[normal]) < 3e-16
    assert got[-1] == 0.0 and got[-2] == 0.0 and got[x.size - 5] == 1.0
