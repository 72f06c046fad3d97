"""Memory and undefined-behaviour checks of the core and the plugin.

Two builds of this checkout, each made once per session:
- with AddressSanitizer and UndefinedBehaviorSanitizer (CMake option
  VISCERA_SANITIZE): the C tests, the abdomen scene stepped from C, and a Python
  process (ASan runtime preloaded) running the cavity task, every integrator,
  a pickled physics, a threaded rollout and a refused config. Any report aborts
  the process (-fno-sanitize-recover), so a clean exit means no report.
- a plain Release build: valgrind memcheck on the abdomen scene's step loop,
  with sine controls that open and close the grasper.
"""

import os
import pathlib
import shutil
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
ABDOMEN = ROOT / "assets" / "scenes" / "abdomen.xml"
IN_CI = bool(os.environ.get("CI"))

needs_toolchain = pytest.mark.skipif(
    shutil.which("cmake") is None or shutil.which("gcc") is None, reason="needs cmake and gcc")


def run(command, env=None, timeout=1200):
    result = subprocess.run([str(c) for c in command], cwd=ROOT, capture_output=True, text=True, env=env,
                            timeout=timeout)
    return result


def build(directory: pathlib.Path, *options: str) -> pathlib.Path:
    generator = ["-G", "Ninja"] if shutil.which("ninja") else []
    for command in (["cmake", "-S", ROOT, "-B", directory, *generator, f"-DPython3_EXECUTABLE={sys.executable}",
                     *options],
                    ["cmake", "--build", directory, "--parallel", "2"]):
        result = run(command)
        assert result.returncode == 0, f"{command}\n{result.stdout[-3000:]}\n{result.stderr[-3000:]}"
    return directory


@pytest.fixture(scope="module")
def sanitized(tmp_path_factory):
    return build(tmp_path_factory.mktemp("sanitized"), "-DVISCERA_SANITIZE=ON", "-DCMAKE_BUILD_TYPE=RelWithDebInfo")


@pytest.fixture(scope="module")
def release(tmp_path_factory):
    return build(tmp_path_factory.mktemp("release"), "-DCMAKE_BUILD_TYPE=Release")


def no_reports(result) -> None:
    output = result.stdout + result.stderr
    assert result.returncode == 0, f"exit {result.returncode}\n{output[-6000:]}"
    for marker in ("ERROR: AddressSanitizer", "ERROR: LeakSanitizer", "runtime error:"):
        assert marker not in output, output[-6000:]


@needs_toolchain
def test_c_tests_and_scene_are_clean_under_sanitizers(sanitized):
    """The core's tests (LeakSanitizer on) and 500 steps of the abdomen scene with moving tools."""
    result = run(["ctest", "--test-dir", sanitized, "--output-on-failure"])
    no_reports(result)
    assert "100% tests passed" in result.stdout
    assert "plugin_abdomen_scene" in result.stdout


PYTHON_SCENE = """
import ctypes, pickle, numpy as np, mujoco, viscera, viscera.tasks
from mujoco import rollout
ctypes.CDLL(None).__asan_report_load8  # the ASan runtime is in this process
assert str(viscera._library.load()) == {library!r}, viscera._library.load()
env = viscera.tasks.load("clear_area", seed=0)
spec = env.action_spec(); rng = np.random.default_rng(0)
env.reset()
for _ in range(25):
    env.step(rng.uniform(spec.minimum, spec.maximum))
twin = pickle.loads(pickle.dumps(env.physics))
twin.step()
for integrator in viscera.allowed_values("integrator"):
    xml = ('<mujoco><worldbody><geom type="plane" size="2 2 .1"/><geom type="box" size=".1 .1 .1" pos=".3 0 .1"/>'
           '</worldbody>' + viscera.extension_xml('g', length=1, control_points=20, shape='line', start=[0, 0, 0.3],
                                                  integrator=integrator) + '</mujoco>')
    m = mujoco.MjModel.from_xml_string(xml); d = mujoco.MjData(m)
    for _ in range(200): mujoco.mj_step(m, d)
    assert np.isfinite(d.plugin_state).all()
    state = np.empty(mujoco.mj_stateSize(m, mujoco.mjtState.mjSTATE_FULLPHYSICS))
    mujoco.mj_getState(m, d, state, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    rollout.rollout(m, [mujoco.MjData(m) for _ in range(2)], np.tile(state, (3, 1)), nstep=20)
try:
    mujoco.MjModel.from_xml_string(xml.replace('value="1"', 'value="nan"', 1))
    raise SystemExit("a NaN length loaded")
except ValueError as error:
    assert "'length'" in str(error)
print("clean")
"""


@needs_toolchain
def test_python_scene_is_clean_under_sanitizers(sanitized):
    """The cavity task, three integrators, a pickle, a threaded rollout and a refused config, in Python."""
    asan = run(["gcc", "-print-file-name=libasan.so"]).stdout.strip()
    assert os.path.isabs(asan), f"no ASan runtime: {asan}"
    library = str((sanitized / "libviscera_plugin.so").resolve())
    env = dict(os.environ, LD_PRELOAD=asan, VISCERA_PLUGIN_LIBRARY=library,
               PYTHONPATH=os.pathsep.join([str(ROOT / "python"), os.environ.get("PYTHONPATH", "")]),
               # CPython's own allocations outlive exit by design; leaks are checked in the C tests
               ASAN_OPTIONS="detect_leaks=0", UBSAN_OPTIONS="print_stacktrace=1")
    result = run([sys.executable, "-c", PYTHON_SCENE.format(library=library)], env=env)
    no_reports(result)
    assert "clean" in result.stdout


def heap_allocations(output: str) -> int:
    """Blocks allocated over the run, from memcheck's heap summary."""
    line = next(l for l in output.splitlines() if "total heap usage" in l)
    return int(line.split("usage:")[1].split("allocs")[0].replace(",", ""))


@pytest.mark.skipif(shutil.which("valgrind") is None and not IN_CI, reason="needs valgrind (CI installs it)")
@needs_toolchain
def test_valgrind_memcheck_on_the_scene_step_loop_is_clean(release):
    """The abdomen scene under memcheck: no invalid access, no uninitialised jump, no leak, and
    no heap allocation per step (200 more steps allocate no more blocks than 100)."""
    outputs = {}
    for steps in (100, 300):
        result = run(["valgrind", "--tool=memcheck", "--error-exitcode=99", "--leak-check=full",
                      "--errors-for-leak-kinds=definite,indirect", "--track-origins=yes",
                      release / "viscera_scene_steps", release / "libviscera_plugin.so", ABDOMEN, steps])
        output = outputs[steps] = result.stdout + result.stderr
        assert result.returncode == 0, output[-6000:]
        assert "ERROR SUMMARY: 0 errors" in output
        assert f"{steps} steps" in result.stdout
    assert heap_allocations(outputs[300]) == heap_allocations(outputs[100])


# A value each kind of config key refuses (viscera.attribute_docs()[key]["kind"]).
BAD_VALUES = {"positive": ["-1", "0", "nan"], "nonnegative": ["-1", "inf"], "count": ["0", "-3", "2.5"],
              "vector": ["x", "1 2 nan"], "choice": ["nonsense"], "taper": ["0", "0.01 0.02 0.03"],
              "real": ["nan"], "custom": ["x y z"]}


def bad_configurations() -> dict[str, tuple[str, str | None]]:
    """A minimal scene per key and bad value (the key set to it, the rest default), and the fuzz
    corpus's inputs: name -> (MJCF text, the key a refusal must name, or None)."""
    import viscera
    scenes = {}
    for key, row in viscera.attribute_docs().items():
        for i, value in enumerate(BAD_VALUES[row["kind"]]):
            scenes[f"{key}_{i}"] = (
                '<mujoco><worldbody><geom type="plane" size="1 1 .1"/><body name="tool"><geom size=".01"/>'
                '<site name="tip"/><joint name="jaw" type="slide"/></body></worldbody><extension>'
                '<plugin plugin="viscera.intestine"><instance name="g">'
                + ('' if key == "length" else '<config key="length" value="0.5"/>')
                + f'<config key="{key}" value="{value}"/></instance></plugin></extension></mujoco>', key)
    for path in sorted((ROOT / "tests" / "python" / "fuzz_corpus").glob("*.xml")):
        scenes[path.stem] = (path.read_text(), None)
    return scenes


@needs_toolchain
def test_every_bad_configuration_is_refused_at_load_from_c_never_aborted(release, tmp_path):
    """No user input reaches mju_error, whose default handler exits a C host: each key set to a
    value its kind refuses, and every input of the fuzz corpus, loaded by a C program with
    MuJoCo's default handlers, either loads and steps (exit 0) or is refused at load with a
    message that names the attribute (exit 2)."""
    refused = 0
    for name, (xml, key) in bad_configurations().items():
        scene = tmp_path / f"{name}.xml"
        scene.write_text(xml)
        result = run([release / "viscera_scene_steps", release / "libviscera_plugin.so", scene, 20], timeout=120)
        output = result.stdout + result.stderr
        assert result.returncode in (0, 2), f"{name}: exit {result.returncode}\n{output[-2000:]}"
        if result.returncode == 2:
            refused += 1
            assert "cannot load" in output and (key is None or f"'{key}'" in output), f"{name}: {output[-2000:]}"
    assert refused >= 60  # most of the bad values are refused, not quietly taken
