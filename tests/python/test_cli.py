"""The command lines: a user's mistake is one clear line before any simulation; --help everywhere.

Runs that must fail are given --duration 1e5 (hours of stepping) and a timeout far below
that: a tool that simulated before checking its input times out instead of passing.
"""

import argparse
import importlib
import os
import pathlib
import re
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
SCENES = ROOT / "assets" / "scenes"
PLANE = SCENES / "fall_on_plane.xml"
QUICK = 60  # s: loading and checking takes about one
LONG = 1e5  # simulated s: hours of stepping, so an error that comes after any simulation times out
TOOL_SCRIPTS = ROOT / "python" / "tools"  # the checkout's tools, not installed (tests/python/conftest.py)
# every command: its name in usage lines, and the module whose main() it runs
TOOLS = {"python -m viscera": "viscera.__main__",
         "python -m viscera.meshcat_server": "viscera.meshcat_server",
         **{f"python python/tools/{name}.py": name.replace("/", ".")
            for name in ("settle", "soak", "validate", "validation/peers", "bench_fall", "bench_cavity",
                         "bench_rollout", "bench_scale", "bench_pixels", "pixel_pictures", "task_rates",
                         "task_pictures", "digest", "bench_versus", "learning/bc", "learning/rl_grasp_lift",
                         "learning/dataset_speed")}}


def command(prog: str) -> list[str]:
    """The argv that runs `prog` from the checkout's root."""
    words = prog.split()
    return [sys.executable, *words[1:3]] if words[1] == "-m" else [sys.executable, str(ROOT / words[1])]


def viscera(*args, cwd=None, timeout=QUICK, prog="python -m viscera") -> subprocess.CompletedProcess:
    return subprocess.run([*command(prog), *map(str, args)], capture_output=True, text=True, cwd=cwd, timeout=timeout)


def scene(tmp_path, old: str, new: str) -> pathlib.Path:
    """fall_on_plane.xml with `old` replaced by `new`."""
    text = PLANE.read_text()
    assert old in text
    path = tmp_path / "scene.xml"
    path.write_text(text.replace(old, new))
    return path


def assert_one_line(result, *names):
    """Failed with exactly one stderr line, naming each of `names`, no traceback."""
    assert result.returncode not in (0, None), result.stdout
    lines = result.stderr.splitlines()
    assert len(lines) == 1 and lines[0].strip(), result.stderr
    for name in names:
        assert str(name) in lines[0], (name, lines[0])
    return lines[0]


def assert_usage_error(result, usage, *names):
    """argparse's usage error: status 2, the tool's usage, then one error line naming `names`."""
    assert result.returncode == 2, result.stderr
    assert "Traceback" not in result.stderr
    assert result.stderr.startswith(f"usage: {usage} "), result.stderr
    error = result.stderr.strip().splitlines()[-1]
    assert error.startswith(f"{usage}: error: "), result.stderr
    for name in names:
        assert str(name) in error, (name, error)


# --- python -m viscera run: bad scenes (status 1, one line) ---

@pytest.mark.parametrize("old, new, names", [
    ('key="length"', 'key="lenght"', ["unknown config key 'lenght'", "did you mean 'length'"]),  # misspelled
    ('key="radius" value="0.0125"', 'key="radius" value="-1"', ["radius", "-1"]),  # bad config value
    ("</worldbody>", "", ["XML"]),  # malformed
    ("<light ", "<lamp ", ["lamp"])], ids=["misspelled-key", "bad-value", "malformed", "unknown-element"])
def test_run_reports_a_bad_scene_in_one_line(tmp_path, old, new, names):
    path = scene(tmp_path, old, new)
    line = assert_one_line(viscera("run", path, "--duration", LONG, "--quiet"), path, *names)
    assert line.startswith(f"python -m viscera run: error: {path}: ") and "viscera.intestine'" not in line  # no stray quote


def test_run_reports_a_missing_scene(tmp_path):
    missing = tmp_path / "nowhere.xml"
    assert_one_line(viscera("run", missing, "--duration", LONG), missing, "no such scene file")


# --- bad options: argparse's usage error (status 2) or one line once the scene is known ---

@pytest.mark.parametrize("option, value, names", [
    ("--duration", "nan", ["nan"]), ("--duration", "inf", ["inf"]), ("--duration", "-1", ["-1"]),
    ("--duration", "0", ["0"]), ("--record-fps", "0", ["0"]), ("--record-fps", "nan", ["nan"]),
    ("--png", "x.txt", ["x.txt", ".png"]), ("--record", "x.txt", ["x.txt", ".html"]),
    ("--png", "{tmp}/no/such/folder/out.png", ["folder", "does not exist"]),
    ("--record", "{tmp}/no/such/folder/run.html", ["folder", "does not exist"]),
    ("--duration", "1e308", ["1e308", "at most"]), ("--record-fps", "1e-308", ["1e-308", "at least"]),
    ("--durration", "1", ["unrecognized arguments", "--durration", "did you mean --duration?"]),  # run's, not the top level's
])
def test_run_refuses_a_bad_option_in_one_line(tmp_path, option, value, names):
    """One line, argparse's usage block left out: the line that matters is the only one."""
    value = value.format(tmp=tmp_path)
    duration = [] if option == "--duration" else ["--duration", LONG]
    result = viscera("run", PLANE, option, value, *duration, "--quiet", cwd=tmp_path)
    line = assert_one_line(result, option, *names)
    assert result.returncode == 2 and line.startswith("python -m viscera run: error: ")


@pytest.mark.parametrize("args, names", [
    (["rn", "x.xml"], ["invalid choice 'rn'", "did you mean 'run'?"]),
    ([], ["required: COMMAND"]),
    (["record", "clear_aera", "--seed", "1", "--policy", "scripted", "--out", "a.npz"], ["did you mean 'clear_area'?"]),
    (["record", "clear_area", "--policy", "scripted", "--out", "a.npz"], ["required", "--seed"]),
    (["record", "clear_area", "--seed", "-1", "--policy", "scripted", "--out", "a.npz"], ["--seed", "-1"]),
    (["record", "clear_area", "--seed", "1", "--policy", "smart", "--out", "a.npz"], ["smart", "scripted, random, idle"]),
    (["record", "clear_area", "--seed", "1", "--policy", "idle", "--out", "a.txt"], ["--out", ".npz"]),
    (["record", "clear_area", "--seed", "1", "--policy", "idle", "--out", "a.npz", "--time-limit", "0"], ["--time-limit"]),
    (["record", "clear_area", "--sed", "1", "--policy", "idle", "--out", "a.npz"], ["did you mean --seed?"]),
    (["play", "grasp_lfit"], ["did you mean 'grasp_lift'?"]),
    (["play", "grasp_lift", "--policy", "smart"], ["smart", "scripted, random, idle"]),
    (["play", "grasp_lift", "--seed", "-1"], ["--seed", "-1"]),
    (["replay", "nope.npz"], ["nope.npz", "no such file"]),
    (["replay", "{tmp}/x.npz", "--json", "x.txt"], ["--json", ".json"]),
    (["replay", "{tmp}"], ["is a folder"]),
    (["replay", "{tmp}/x.npz", "--trajectoy", "t.json"], ["did you mean --trajectory?"]),
    (["teleop", "clear_area", "--device", "mouse"], ["mouse", "keyboard, gamepad, spacemouse, socket"]),
    (["teleop", "clear_area", "--port", "70000"], ["--port", "70000"]),
    (["view"], ["required: scene"]),
    (["-x"], ["required: COMMAND", "-x: no such option"]),
    (["record", "clear_area", "--seed", "4294967296", "--policy", "idle", "--out", "a.npz"], ["--seed", "2^32 - 1"]),
    (["record", "clear_area", "--policy", "idle", "--out", "a.npz", "-s", "1"],
     ["required: --seed", "-s: no such option"]),
    (["replay", "--jsn", "{tmp}/x.json"], ["--jsn: did you mean --json?"]),  # argparse took x.json for the recording
    (["teleop", "clear_area", "--port", "47001"], ["--port", "--device socket"]),
    (["teleop", "clear_area", "--haptic-cpu", "1"], ["--haptic-cpu", "--device socket"]),
    (["teleop", "clear_area", "--haptic-cpu", "x"], ["--haptic-cpu", "x"]),
    (["teleop", "clear_area", "--time-limit", "nan"], ["--time-limit", "nan"]),
    (["view", "x.xml", "--camera", "0"], ["--camera: no such option"]),
])
def test_every_command_refuses_a_mistake_in_one_line(tmp_path, args, names):
    (tmp_path / "x.npz").write_bytes(b"")
    result = viscera(*[a.format(tmp=tmp_path) for a in args], cwd=tmp_path)
    assert_one_line(result, *names)
    assert result.returncode == 2


def test_version():
    result = viscera("--version")
    assert result.returncode == 0 and re.fullmatch(r"viscera \S+, mujoco \d+\.\d+\.\d+\n", result.stdout), result


def test_run_lists_the_cameras_for_an_unknown_one(tmp_path):
    result = viscera("run", SCENES / "abdomen.xml", "--camera", "endoscope", "--duration", LONG, "--quiet",
                     "--png", tmp_path / "out.png")
    assert_one_line(result, "--camera", "endoscope", "overview", "top")
    assert result.returncode == 2 and not (tmp_path / "out.png").exists()


def test_run_refuses_a_duration_below_one_step():
    assert_one_line(viscera("run", PLANE, "--duration", 1e-4), "--duration", "0.0001", "timestep")


def test_hold_needs_the_live_viewer():
    assert_one_line(viscera("run", PLANE, "--duration", LONG, "--hold"), "--hold", "--viewer meshcat")


def test_run_refuses_a_host_it_cannot_serve_on():
    result = viscera("run", PLANE, "--duration", LONG, "--quiet", "--viewer", "meshcat",
                     "--host", "no.such.host.invalid")
    assert_one_line(result, "--host", "no.such.host.invalid")


def test_verbose_prints_the_traceback_too(tmp_path):
    path = scene(tmp_path, 'key="length"', 'key="lenght"')
    result = viscera("run", path, "--duration", LONG, "--verbose")
    assert result.returncode == 1
    assert "Traceback" in result.stderr and "ValueError" in result.stderr
    assert result.stderr.splitlines()[-1].startswith(f"python -m viscera run: error: {path}: ")


def _start(tmp_path, *args) -> tuple[subprocess.Popen, pathlib.Path, pathlib.Path]:
    """`python -m viscera run *args` in the background, its output going to files."""
    out, err = tmp_path / "stdout", tmp_path / "stderr"
    with open(out, "w") as stdout, open(err, "w") as stderr:
        # Ctrl-C as a person's terminal delivers it: a runner that started us in the background
        # with SIGINT ignored (a non-interactive shell's `&`) must not pass that on to the command
        process = subprocess.Popen([sys.executable, "-m", "viscera", "run", *map(str, args)], stdout=stdout,
                                   stderr=stderr, preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    return process, out, err


def _wait_for(process, path: pathlib.Path, text: str) -> None:
    deadline = time.monotonic() + QUICK
    while text not in path.read_text():
        assert process.poll() is None and time.monotonic() < deadline, path.read_text()
        time.sleep(0.1)


def test_ctrl_c_ends_a_run_in_one_line(tmp_path):
    process, _, err = _start(tmp_path, PLANE, "--duration", LONG)
    try:
        _wait_for(process, err, "step")  # the progress bar: it is stepping
        process.send_signal(signal.SIGINT)
        process.wait(timeout=QUICK)
    finally:
        if process.poll() is None:
            process.kill()
    stderr = err.read_text()
    assert process.returncode == 130, stderr
    assert "Traceback" not in stderr
    assert stderr.strip().splitlines()[-1] == "python -m viscera run: interrupted"


def test_hold_serves_the_final_state_until_ctrl_c(tmp_path):
    process, out, err = _start(tmp_path, PLANE, "--duration", 0.1, "--quiet", "--viewer", "meshcat",
                               "--camera", "overview", "--hold")
    try:
        _wait_for(process, out, "Ctrl-C to stop")
        assert "intestine 'intestine'" in out.read_text()  # the summary came first
        time.sleep(1.0)
        assert process.poll() is None  # still serving
        process.send_signal(signal.SIGINT)
        process.wait(timeout=QUICK)
    finally:
        if process.poll() is None:
            process.kill()
    assert process.returncode == 0, err.read_text()
    assert "Traceback" not in err.read_text()


def test_a_good_run_still_works(tmp_path):
    result = viscera("run", PLANE, "--duration", 0.1, "--quiet", "--camera", "0", "--png", tmp_path / "out.png")
    assert result.returncode == 0, result.stderr
    assert "simulated time   0.100 s" in result.stdout and (tmp_path / "out.png").stat().st_size > 1000


def test_view_reports_a_missing_scene_in_one_line(tmp_path):
    assert_one_line(viscera("view", tmp_path / "nope.xml"), "nope.xml", "no such scene file")


def test_view_without_a_display_says_what_works_instead(tmp_path):
    """No display: one line naming the headless alternatives, before any window is tried."""
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    result = subprocess.run([*command("python -m viscera"), "view", str(SCENES / "abdomen.xml")], capture_output=True,
                            text=True, timeout=QUICK, env=env)
    assert result.returncode == 2
    assert_one_line(result, "needs a display", "--png", "--viewer meshcat")


# --- every tool ---

@pytest.mark.parametrize("prog", TOOLS)
def test_help_of_every_tool(prog):
    result = viscera("--help", prog=prog, timeout=30)  # peers used to run its comparison
    assert result.returncode == 0, result.stderr
    assert result.stdout.startswith(f"usage: {prog} "), result.stdout
    assert "``" not in result.stdout or prog != "python -m viscera"  # no RST markup


class _Parsed(Exception):
    pass


@pytest.mark.parametrize("prog", TOOLS)
def test_every_option_has_a_help_text(monkeypatch, prog):
    """The parser each main() builds (caught at parse_args), subcommands included."""
    parsers = []

    def catch(self, *args, **kwargs):
        parsers.append(self)
        raise _Parsed

    monkeypatch.setattr(argparse.ArgumentParser, "parse_args", catch)
    monkeypatch.setattr(argparse.ArgumentParser, "parse_known_args", catch)
    with pytest.raises(_Parsed):
        importlib.import_module(TOOLS[prog]).main([])
    missing = []
    while parsers:
        parser = parsers.pop()
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                parsers += action.choices.values()
            elif not action.help:
                missing.append(f"{parser.prog} {'/'.join(action.option_strings) or action.dest}")
    assert not missing


SETTLE = "python python/tools/settle.py"


@pytest.mark.parametrize("prog, args, names", [
    ("python python/tools/soak.py", ["--minutes", "-1"], ["--minutes", "-1"]),
    ("python python/tools/bench_versus.py", ["no/such/python"], ["no/such/python", "no such file"]),
    ("python python/tools/bench_fall.py", ["--duration", "nan"], ["--duration", "nan"]),
    ("python python/tools/bench_pixels.py", ["--sizes", "0"], ["--sizes", "0"]),
    ("python python/tools/bench_scale.py", ["--parts", "pixels"], ["--parts", "pixels"]),
    (SETTLE, ["--out", "s.xml", "--duration", "inf"], ["--duration", "inf"]),
])
def test_other_tools_check_their_options_first(tmp_path, prog, args, names):
    assert_usage_error(viscera(*args, prog=prog, cwd=tmp_path), prog, *names)


# --- settle ---

def _points(path: pathlib.Path) -> np.ndarray:
    return np.array(re.search(r'<config key="points" value="([^"]*)"/>', path.read_text()).group(1).split(), float)


def test_settle_writes_nothing_without_an_output_path(tmp_path):
    shipped = tmp_path / "assets" / "scenes" / "abdomen.xml"  # where it used to write by default
    shipped.parent.mkdir(parents=True)
    shipped.write_text((SCENES / "abdomen.xml").read_text())
    before = shipped.stat().st_mtime_ns
    result = viscera(prog=SETTLE, cwd=tmp_path)
    assert_usage_error(result, SETTLE, "--out")
    assert shipped.stat().st_mtime_ns == before


def test_settle_reports_a_missing_scene(tmp_path):
    result = viscera("--scene", tmp_path / "none.xml", "--out", tmp_path / "out.xml", prog=SETTLE)
    assert_one_line(result, "settle.py: error:", "none.xml")
    assert not (tmp_path / "out.xml").exists()


def test_settle_refuses_an_intestine_too_long_for_the_cavity(tmp_path):
    text = (SCENES / "abdomen.xml").read_text()
    assert 'key="length" value="3"' in text
    long = tmp_path / "long.xml"
    long.write_text(text.replace('key="length" value="3"', 'key="length" value="30"'))
    result = viscera("--scene", long, "--out", tmp_path / "out.xml", "--duration", LONG, prog=SETTLE)
    assert_one_line(result, "settle.py: error:", "long.xml", "15.00 m asked")  # per half
    assert not (tmp_path / "out.xml").exists()


def test_settle_defaults_reproduce_the_shipped_scene(tmp_path):
    """The default settling time is the one the shipped abdomen was settled with."""
    out = tmp_path / "settled.xml"
    result = viscera("--out", out, "--quiet", prog=SETTLE, cwd=ROOT, timeout=300)
    assert result.returncode == 0, result.stderr
    assert np.abs(_points(out) - _points(SCENES / "abdomen.xml")).max() < 2e-6  # written to 1e-6 m


# --- peers ---

def test_peers_hint_names_the_projects_extra(monkeypatch):
    from validation import peers
    monkeypatch.setattr(peers, "available", lambda peer: False)
    assert 'pip install ".[peers]"' in peers.run_peer("pyelastica", "cantilever", 4)["unsupported"]


# --- run --record / --hold: the recording and the held page ---

def _recorded_paths(page: pathlib.Path) -> list[str]:
    """The paths a saved recording draws."""
    import base64

    import umsgpack
    return [umsgpack.unpackb(base64.b64decode(b64))["path"] for b64 in re.findall(r'draw\("([A-Za-z0-9+/=]*)"\)',
                                                                                   page.read_text())]


def test_a_short_recording_has_the_first_and_final_states_and_no_server(tmp_path):
    page = tmp_path / "short.html"
    result = viscera("run", PLANE, "--duration", 0.05, "--quiet", "--record", page)
    assert result.returncode == 0, result.stderr
    assert "(2 frames," in result.stdout and "meshcat viewer" not in result.stdout  # a recording needs no server
    paths = _recorded_paths(page)
    assert {"/meshcat/recording/intestine/0", "/meshcat/recording/intestine/1"} <= set(paths)


def test_a_recording_without_the_viewer_starts_no_process(tmp_path, monkeypatch):
    from viscera.__main__ import run

    def no_process(*args, **kwargs):
        raise AssertionError(f"started {args}")

    monkeypatch.setattr(subprocess, "Popen", no_process)
    summary = run(str(PLANE), 0.01, quiet=True, record=str(tmp_path / "run.html"))
    assert summary["recording_frames"] == 2


def test_a_recording_plays_at_the_rate_it_was_recorded_at(tmp_path, monkeypatch):
    from viscera.__main__ import run
    from viscera.viewer import MeshcatViewer
    rates = []
    save = MeshcatViewer.save
    monkeypatch.setattr(MeshcatViewer, "save", lambda self, path, fps: rates.append(fps) or save(self, path, fps))
    summary = run(str(PLANE), 0.1, quiet=True, record=str(tmp_path / "run.html"), record_fps=300)
    # 300 frames per s at a 2 ms step: every second step, 250 frames per s; 0 to 50 steps, both ends
    assert rates == [pytest.approx(250.0)] and summary["recording_frames"] == 26


def test_record_fps_above_the_step_rate_is_refused():
    result = viscera("run", PLANE, "--duration", 1000, "--quiet", "--record", "x.html", "--record-fps", 1000)
    assert_one_line(result, "--record-fps", "1000", "500")
    assert result.returncode == 2


def test_hold_reports_a_server_that_died(tmp_path):
    import os
    process, out, err = _start(tmp_path, PLANE, "--duration", 0.1, "--quiet", "--viewer", "meshcat", "--hold")
    try:
        _wait_for(process, out, "Ctrl-C to stop")
        children = pathlib.Path(f"/proc/{process.pid}/task/{process.pid}/children").read_text().split()
        servers = [pid for pid in children if b"viscera.meshcat_server" in pathlib.Path(f"/proc/{pid}/cmdline").read_bytes()]
        assert len(servers) == 1
        os.kill(int(servers[0]), signal.SIGKILL)
        process.wait(timeout=QUICK)
    finally:
        if process.poll() is None:
            process.kill()
    assert_one_line(subprocess.CompletedProcess([], process.returncode, out.read_text(), err.read_text()),
                    "--hold", "meshcat server stopped")
