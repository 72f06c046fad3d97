"""Fuzzing recordings: whatever a recording file's bytes, reading it either gives back the recording
it was (the mutation did not matter: it replays bit for bit) or refuses it with one RecordingError
line naming the file; never another exception, never a warning (they are errors here).

A few short real recordings are mutated deterministically (numpy's default_rng(seed), mutant i
from seed i): flipped bytes, cuts, the zip's local and central headers changed (compression
method, sizes, name lengths, offsets), the .npy headers corrupted (and the zip's CRC made right,
so that numpy's header parser gets the bytes), extreme numbers written into the meta's values and
the actions (1e308, -0.0, NaN, inf, 5e-324, integers of 2^64 and of 400 digits), entries removed,
duplicated, renamed or added. Only the reading path runs for most: a mutant whose replayed inputs
(task, scene, seed, control period, time limit, actions' bits) are the original's needs no replay
(a replay is deterministic: a few are replayed to show it); one whose inputs changed and still
load is replayed, and must end either in the recorded state or in a state the replay command
refuses in one line.

In CI: VISCERA_RECORDING_MUTANTS mutants (default 2000, about 10 s). The full run, one process:

    python tests/python/test_recording_fuzz.py --count 10000
"""

from __future__ import annotations

import argparse
import collections
import io
import json
import os
import pathlib
import struct
import subprocess
import sys
import time
import warnings
import zipfile

import numpy as np
import pytest

from viscera import recording as rec

MUTANTS = int(os.environ.get("VISCERA_RECORDING_MUTANTS", "2000"))
# the originals: (task, seed, policy, time limit s); short, of two tasks with different action widths
ORIGINALS = (("grasp_lift", 2, "random", 0.2), ("clear_area", 5, "random", 0.1))
EXTREME_FLOATS = (1e308, -1e308, -0.0, float("nan"), float("inf"), -float("inf"), 5e-324, 1e-300, 0.0, -1.0, 1e16)
EXTREME_JSON = EXTREME_FLOATS + (2 ** 64, -1, 0, 2 ** 32, 10 ** 400, True, None, "", "x" * 5000, [], {}, [[[]]])
COMPRESSION_METHODS = (0, 1, 6, 8, 9, 12, 14, 93, 95, 98, 99, 0xFFFF)  # stored, shrunk, ..., deflate, bzip2, lzma, AES


# -- the originals and the archive's parts

def make_originals(folder: pathlib.Path) -> list[tuple[pathlib.Path, rec.Recording]]:
    """ORIGINALS, then the first again with a steered laparoscope's track (30 degree optics): the
    camera moves no physics, so the recorded final state holds."""
    originals = []
    for task, seed, policy, limit in ORIGINALS:
        path = folder / f"{task}.npz"
        rec.record(task, seed=seed, policy=policy, time_limit_s=limit).save(path)
        originals.append((path, rec.load(path)))
    steered = rec.load(originals[0][0])
    ramp = np.linspace(0.0, 1.0, steered.steps)[:, None]
    steered.camera = np.array([10.0, -5.0, 0.03, 0.0]) + ramp * np.array([5.0, 5.0, 0.01, 30.0])
    steered.optics_deg = 30.0
    path = folder / "steered.npz"
    steered.save(path)
    originals.append((path, rec.load(path)))
    return originals


def entries(whole: bytes) -> dict[str, bytes]:
    """The .npy bytes of each entry of an intact archive (name -> bytes, in order)."""
    with zipfile.ZipFile(io.BytesIO(whole)) as archive:
        return {info.filename: archive.read(info) for info in archive.infolist()}


def archive(members: list[tuple[str, bytes]], compression: int = zipfile.ZIP_DEFLATED) -> bytes:
    """A zip of `members` (duplicates kept: zipfile warns of them, which is not what is tested)."""
    out = io.BytesIO()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # "Duplicate name"
        with zipfile.ZipFile(out, "w", compression) as zipped:
            for name, data in members:
                zipped.writestr(name, data)
    return out.getvalue()


def npy(array: np.ndarray) -> bytes:
    out = io.BytesIO()
    np.save(out, array, allow_pickle=False)
    return out.getvalue()


def npy_parts(data: bytes) -> tuple[bytes, bytes, bytes]:
    """A version 1.0 .npy's magic and length (10 bytes), header text and the array's bytes."""
    length = struct.unpack("<H", data[8:10])[0]
    return data[:10], data[10:10 + length], data[10 + length:]


def meta_of(members: dict[str, bytes]) -> dict:
    return json.loads(npy_parts(members["meta.npy"])[2].decode())


def with_meta(members: dict[str, bytes], meta: dict) -> dict[str, bytes]:
    text = json.dumps(meta, allow_nan=True).encode()
    return {**members, "meta.npy": npy(np.frombuffer(text, dtype=np.uint8))}


# -- the mutations: each (rng, the original's bytes) -> (what was done, the mutant's bytes)

def flip_bytes(rng, whole: bytes):
    data = bytearray(whole)
    where = rng.integers(0, len(data), size=int(rng.integers(1, 5)))
    for i in where:
        data[i] ^= int(rng.integers(1, 256))
    return f"bytes flipped at {sorted(where.tolist())}", bytes(data)


def truncate(rng, whole: bytes):
    cut = int(rng.integers(0, len(whole)))
    return f"cut to {cut} bytes", whole[:cut]


def zip_header(rng, whole: bytes):
    """A field of a local (PK 3 4) or central (PK 1 2) header: the compression method, the sizes,
    the CRC, the name's or extra field's length, the local header's offset."""
    central = bool(rng.integers(0, 2))
    signature = b"PK\x01\x02" if central else b"PK\x03\x04"
    starts = [i for i in range(len(whole)) if whole.startswith(signature, i)]
    start = starts[int(rng.integers(0, len(starts)))]
    # field: (offset in the header, struct format)
    fields = ({"method": (10, "<H"), "crc": (16, "<I"), "compressed size": (20, "<I"), "size": (24, "<I"),
               "name length": (28, "<H"), "extra length": (30, "<H"), "offset": (42, "<I")} if central else
              {"method": (8, "<H"), "crc": (14, "<I"), "compressed size": (18, "<I"), "size": (22, "<I"),
               "name length": (26, "<H"), "extra length": (28, "<H")})
    field = list(fields)[int(rng.integers(0, len(fields)))]
    offset, kind = fields[field]
    old = struct.unpack_from(kind, whole, start + offset)[0]
    top = 0xFFFF if kind == "<H" else 0xFFFFFFFF
    value = int(rng.choice([0, 1, max(old - 1, 0), min(old + 1, top), top, int(rng.integers(0, top + 1))]))
    if field == "method":
        value = int(rng.choice(COMPRESSION_METHODS))
    data = bytearray(whole)
    struct.pack_into(kind, data, start + offset, value)
    return f"{'central' if central else 'local'} header at {start}: {field} {old} -> {value}", bytes(data)


NPY_HEADERS = (  # whole header texts, the TokenError one (an unclosed bracket over lines) first
    "{'descr': '<f8', 'fortran_order': False, 'shape': (10, \n",
    "{'descr': '<f8', 'fortran_order': False, 'shape': (10, 5), '\n",
    "{'descr': '<f8', 'fortran_order': False, 'shape': (10, 5)\n",
    "{'descr': '>f8', 'fortran_order': False, 'shape': (10, 5), }\n",
    "{'descr': '|O', 'fortran_order': False, 'shape': (10, 5), }\n",
    "{'descr': '<i8', 'fortran_order': False, 'shape': (10, 5), }\n",
    "{'descr': '<f8', 'fortran_order': True, 'shape': (10, 5), }\n",
    "{'descr': '<f8', 'fortran_order': False, 'shape': (10000000000000000000000000000, 5), }\n",
    "{'descr': '<f8', 'fortran_order': False, 'shape': (-10, -5), }\n",
    "{'descr': '<f8', 'fortran_order': False, 'shape': (2, 25), }\n",
    "{'descr': '<f8', 'fortran_order': False, 'shape': (), }\n",
    "{'descr': [('a', '<f8')], 'fortran_order': False, 'shape': (10, 5), }\n",
    "{'descr': '<f8', 'fortran_order': False, 'shape': (10, 5), 'extra': 1}\n",
    "[1, 2, 3]\n",
    "\x00\xff{\n",
)


def npy_header(rng, whole: bytes):
    """An entry's .npy header replaced or garbled (magic, version, length, text), the archive
    rebuilt with right CRCs so that numpy's parser reads it."""
    members = entries(whole)
    name = list(members)[int(rng.integers(0, len(members)))]
    magic, header, body = npy_parts(members[name])
    how = int(rng.integers(0, 4))
    if how == 0:
        text = NPY_HEADERS[int(rng.integers(0, len(NPY_HEADERS)))].encode("latin1")
        data, what = magic[:8] + struct.pack("<H", len(text)) + text + body, f"header {text!r}"
    elif how == 1:
        garbled = bytearray(header)
        for i in rng.integers(0, len(garbled), size=int(rng.integers(1, 4))):
            garbled[i] = int(rng.integers(0, 256))
        data, what = magic + bytes(garbled) + body, f"header garbled to {bytes(garbled)!r}"
    elif how == 2:
        length = int(rng.choice([0, 1, len(header) - 1, len(header) + 1, 0xFFFF]))
        data, what = magic[:8] + struct.pack("<H", length) + header + body, f"header length {length}"
    else:
        version = bytes([int(rng.integers(0, 5)), int(rng.integers(0, 2))])
        data, what = magic[:6] + version + magic[8:] + header + body, f"npy version {tuple(version)}"
    return f"{name}: {what}", archive(list({**members, name: data}.items()))


META_KEYS = ("version", "task", "scene", "seed", "policy", "policy_seed", "control_timestep_s", "time_limit_s",
             "steps", "success", "final_state_sha256", "created", "viscera", "format", "camera")


def extreme_meta(rng, whole: bytes):
    """A meta value made extreme (or the meta's JSON text garbled, its CRC right)."""
    members = entries(whole)
    meta = meta_of(members)
    if rng.integers(0, 4) == 0:
        text = bytearray(json.dumps(meta).encode())
        for i in rng.integers(0, len(text), size=int(rng.integers(1, 3))):
            text[i] = int(rng.integers(32, 127))
        changed = {**members, "meta.npy": npy(np.frombuffer(bytes(text), dtype=np.uint8))}
        return f"meta text {bytes(text)!r}", archive(list(changed.items()))
    key = META_KEYS[int(rng.integers(0, len(META_KEYS)))]
    value = EXTREME_JSON[int(rng.integers(0, len(EXTREME_JSON)))]
    if rng.integers(0, 3) == 0 and key in ("control_timestep_s", "time_limit_s"):  # near the real value
        value = meta[key] * float(rng.choice([1 + 1e-9, 1 + 1e-12, 1.5, 2.0, 0.5, 1e-3]))
    if key == "camera" and rng.integers(0, 2):  # the optics made extreme
        key, value = "camera.optics_deg", value
        meta["camera"] = {"optics_deg": value}
    else:
        meta[key] = value
    return f"meta {key} = {str(value)[:40]}", archive(list(with_meta(members, meta).items()))


def extreme_actions(rng, whole: bytes):
    """Extreme numbers written into the actions (or the camera track, where there is one), or
    either of another dtype or shape."""
    members = entries(whole)
    entry = "camera.npy" if "camera.npy" in members and rng.integers(0, 2) else "actions.npy"
    actions = np.load(io.BytesIO(members[entry]))
    how = int(rng.integers(0, 3))
    if how == 0:
        changed = actions.copy()
        cells = int(rng.integers(1, 4))
        for _ in range(cells):
            changed[int(rng.integers(0, changed.shape[0])), int(rng.integers(0, changed.shape[1]))] = \
                rng.choice(EXTREME_FLOATS)
        what = f"{cells} action values made extreme"
    elif how == 1:
        kind = rng.choice(["<i8", "<f4", ">f8", "<u8", "<c16"])
        changed = (actions * 1e18).astype(kind) if kind in ("<i8", "<u8") else actions.astype(kind)
        what = f"actions as {kind}"
    else:
        shapes = [actions[:-1], actions[:, :-1], actions.reshape(-1), actions[None], actions[:0],
                  np.concatenate([actions, actions])]
        changed = shapes[int(rng.integers(0, len(shapes)))]
        what = f"actions of shape {changed.shape}"
    return f"{entry}: {what}", archive(list({**members, entry: npy(changed)}.items()))


def entry_list(rng, whole: bytes):
    """Entries removed, duplicated, renamed, added or reordered; or stored, not deflated."""
    members = list(entries(whole).items())
    how = int(rng.integers(0, 6))
    name = members[int(rng.integers(0, len(members)))][0]
    if how == 0:
        members = [m for m in members if m[0] != name]
    elif how == 1:
        members = members + [m for m in members if m[0] == name]
    elif how == 2:
        renamed = str(rng.choice(["meta", "meta.npy.npy", "actions.NPY", "x.npy", "meta.npy/"]))
        members = [(renamed if n == name else n, d) for n, d in members]
    elif how == 3:
        members = members + [("extra.npy", npy(np.zeros(3)))]
    elif how == 4:
        members = members[::-1]
    else:
        return "entries stored, not deflated", archive(members, zipfile.ZIP_STORED)
    return f"entries {[n for n, _ in members]}", archive(members)


MUTATIONS = (flip_bytes, truncate, zip_header, npy_header, extreme_meta, extreme_actions, entry_list)


def mutant(index: int, originals: list) -> tuple[str, bytes, int]:
    """Mutant `index`: its description, bytes and original (by number)."""
    rng = np.random.default_rng(index)
    which = int(rng.integers(0, len(originals)))
    mutation = MUTATIONS[int(rng.integers(0, len(MUTATIONS)))]
    what, data = mutation(rng, originals[which][0].read_bytes())
    return f"mutant {index} of {originals[which][0].name}: {mutation.__name__}: {what}", data, which


# -- what a mutant gives

def replayed_inputs(recording: rec.Recording) -> tuple:
    camera = None if recording.camera is None else (recording.optics_deg, recording.camera.tobytes())
    return (recording.task, recording.scene, recording.seed, recording.control_timestep_s, recording.time_limit_s,
            recording.actions.shape, recording.actions.tobytes(), camera)


def outcome(path: pathlib.Path, original: rec.Recording, replay_same: bool = False) -> str:
    """"refused" (one line naming the file), "same" (read back as the original: its replay is),
    "changed: identical" (other inputs, the replay ends in the recorded state anyway) or "changed:
    refused after the replay" (ends elsewhere: the replay command's one line). Any other exception
    or any warning goes up."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        try:
            loaded = rec.load(path)
        except rec.RecordingError as error:
            message = str(error)
            assert message.startswith(f"{path}: ") and "\n" not in message, message
            return "refused"
        if replayed_inputs(loaded) == replayed_inputs(original) and not replay_same:
            return "same"
        result = rec.replay(loaded)  # a RecordingError here would be the replay command's one line too
        if result.matches(loaded):
            rec.trajectories(loaded)  # what replay --trajectory writes after a replay that matched
    if replayed_inputs(loaded) == replayed_inputs(original):
        assert result.final_state_sha256 == original.final_state_sha256, "the same inputs replayed elsewhere"
        return "same"
    return "changed: identical" if result.matches(loaded) else "changed: refused after the replay"


def fuzz(count: int, folder: pathlib.Path, replayed_same: int = 3, first: int = 0):
    """Mutants first .. first + count - 1 of fresh originals in `folder`: the outcomes' counts, and
    by mutation. The first `replayed_same` mutants read back as their original are replayed."""
    originals = make_originals(folder)
    outcomes, by_mutation = collections.Counter(), collections.Counter()
    for index in range(first, first + count):
        what, data, which = mutant(index, originals)
        path = folder / f"mutant{index}.npz"
        path.write_bytes(data)
        try:
            result = outcome(path, originals[which][1], replay_same=outcomes["same"] < replayed_same)
        except BaseException as error:
            raise AssertionError(f"{what}: {type(error).__name__}: {error}") from error
        path.unlink()
        outcomes[result] += 1
        by_mutation[(what.split(": ")[1], result)] += 1
    return outcomes, by_mutation


def test_mutated_recordings_are_read_back_or_refused_in_one_line(tmp_path):
    outcomes, by_mutation = fuzz(MUTANTS, tmp_path)
    assert sum(outcomes.values()) == MUTANTS
    assert outcomes["refused"] > MUTANTS / 2 and outcomes["same"] > 0, outcomes  # the mutations reach the checks
    for mutation in MUTATIONS:  # each made files that were refused
        assert by_mutation[(mutation.__name__, "refused")] > 0, by_mutation


# -- what the outside check found: three tracebacks and RuntimeWarnings, each now one line

def central_headers(data: bytes) -> dict[str, int]:
    """Where each entry's central directory header starts (by its name) in an intact archive."""
    with zipfile.ZipFile(io.BytesIO(data)) as zipped:
        names = [info.filename.encode() for info in zipped.infolist()]
    starts = {}
    for name in names:
        start = data.rindex(b"PK\x01\x02", 0, data.rindex(name))
        starts[name.decode()] = start
    return starts


def rebuilt(original: pathlib.Path, folder: pathlib.Path, name: str, meta: dict | None = None,
            header: str | None = None, method: int | None = None, actions: float | None = None) -> pathlib.Path:
    """`original` with its meta's values changed, or its actions' .npy header text replaced, or
    its actions entry's compression method (the central directory's: the one zipfile reads) set,
    or its last action value set to `actions`."""
    members = entries(original.read_bytes())
    if actions is not None:
        changed = np.load(io.BytesIO(members["actions.npy"]))
        changed[-1, -1] = actions
        members["actions.npy"] = npy(changed)
    if meta is not None:
        members = with_meta(members, {**meta_of(members), **meta})
    if header is not None:
        magic, _, body = npy_parts(members["actions.npy"])
        members["actions.npy"] = magic[:8] + struct.pack("<H", len(header)) + header.encode() + body
    data = bytearray(archive(list(members.items())))
    if method is not None:
        struct.pack_into("<H", data, central_headers(bytes(data))["actions.npy"] + 10, method)
    path = folder / name
    path.write_bytes(bytes(data))
    return path


BAD_FILES = {  # name: (the change, words of the one line)
    "unsupported_compression.npz": ({"method": 1}, "compression method 1"),
    "broken_npy_header.npz": ({"header": NPY_HEADERS[0]}, ".npy header"),
    "huge_control_period.npz": ({"meta": {"control_timestep_s": 1e308}}, "control_timestep_s"),
    "subnormal_control_period.npz": ({"meta": {"control_timestep_s": 5e-324}}, "control_timestep_s"),
    "off_grid_control_period.npz": ({"meta": {"control_timestep_s": 0.0200001}}, "whole number of"),
    "huge_time_limit.npz": ({"meta": {"time_limit_s": 1e308}}, "time_limit_s"),
    "short_time_limit.npz": ({"meta": {"time_limit_s": 1e-300}}, "more than its time limit"),
    "huge_step_count.npz": ({"meta": {"steps": 2 ** 64}}, "steps"),
    "huge_action.npz": ({"actions": 1e308}, "far outside the task's range"),
    "shape_overflow.npz": ({"header": NPY_HEADERS[7]}, "header says shape"),
}


@pytest.fixture(scope="module")
def bad_files(tmp_path_factory) -> dict[str, pathlib.Path]:
    folder = tmp_path_factory.mktemp("bad")
    original = folder / "good.npz"
    rec.record("grasp_lift", seed=2, policy="random", time_limit_s=0.2).save(original)
    return {name: rebuilt(original, folder, name, **change) for name, (change, _) in BAD_FILES.items()}


@pytest.mark.parametrize("name", BAD_FILES)
def test_what_the_outside_check_found_is_refused_in_one_line(bad_files, name):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(rec.RecordingError) as error:
            rec.load(bad_files[name])
    message = str(error.value)
    assert message.startswith(f"{bad_files[name]}: ") and "\n" not in message
    assert BAD_FILES[name][1] in message, message


@pytest.mark.parametrize("name", ["unsupported_compression.npz", "broken_npy_header.npz", "huge_control_period.npz"])
def test_the_replay_command_refuses_them_in_one_line(bad_files, name):
    """Exactly one stderr line, the file named, status 1 (an input's mistake, as a scene's), no
    score: the three that gave tracebacks."""
    result = subprocess.run([sys.executable, "-W", "error::RuntimeWarning", "-m", "viscera", "replay",
                             str(bad_files[name]), "--quiet"], capture_output=True, text=True, timeout=300)
    lines = result.stderr.splitlines()
    assert result.returncode == 1 and len(lines) == 1, result.stderr
    assert lines[0].startswith(f"python -m viscera replay: error: {bad_files[name]}: "), lines[0]
    assert BAD_FILES[name][1] in lines[0] and result.stdout == ""


def test_the_dataset_command_refuses_a_folder_holding_one_in_one_line(bad_files, tmp_path):
    """dataset --policy recordings reads each file with the same reader: one line naming the
    file, status 2 (the option's mistake), no dataset."""
    pytest.importorskip("minari")
    folder = tmp_path / "recordings"
    folder.mkdir()
    (folder / "broken.npz").write_bytes(bad_files["broken_npy_header.npz"].read_bytes())
    out = tmp_path / "dataset"
    result = subprocess.run([sys.executable, "-W", "error::RuntimeWarning", "-m", "viscera", "dataset", "grasp_lift",
                             "--format", "minari", "--out", str(out), "--policy", "recordings", str(folder), "--quiet"],
                            capture_output=True, text=True, timeout=300)
    lines = result.stderr.splitlines()
    assert result.returncode == 2 and len(lines) == 1, result.stderr
    assert lines[0].startswith("python -m viscera dataset: error: --policy recordings ") and \
        f"{folder / 'broken.npz'}: corrupt" in lines[0], lines[0]
    assert not out.exists()


def main() -> None:
    """The long run: `--count` mutants, their outcomes and the wall time."""
    import tempfile
    parser = argparse.ArgumentParser(description="Mutate recordings and read (or replay) each.")
    parser.add_argument("--count", type=int, default=10000)
    parser.add_argument("--first", type=int, default=0, help="the first mutant's number (its seed)")
    args = parser.parse_args()
    start = time.perf_counter()
    with tempfile.TemporaryDirectory() as folder:
        outcomes, by_mutation = fuzz(args.count, pathlib.Path(folder), first=args.first)
    wall = time.perf_counter() - start
    for (mutation, result), value in sorted(by_mutation.items()):
        print(f"{value:6d}  {mutation}: {result}")
    for result, value in sorted(outcomes.items()):
        print(f"{value:6d}  {result}")
    print(f"{args.count} mutants in {wall:.0f} s: no exception but RecordingError, no warning")


if __name__ == "__main__":
    main()
