"""Fuzzing what users write: random and malformed plugin configs in random MJCF scenes.

The promise: every input either loads and steps with a finite state (qpos,
qvel, plugin state, sensors, axis, skin and drawn geoms), or is refused at
load with a ValueError that names one of the attributes it set. It never
crashes and never hangs.

Why hypothesis rather than atheris or libFuzzer: the inputs are structured
(MJCF scenes and about 40 typed config keys whose bad values are the point),
and the code under test is C behind MuJoCo's parser, where a byte-level
coverage-guided fuzzer spends its time on XML syntax MuJoCo already rejects.
Hypothesis generates typed scenes, shrinks a failure to a minimal scene that
a person can read, runs under pytest with no extra toolchain (atheris needs
clang and an instrumented build), and replays its finds. Each input runs in a
worker process (fuzz_worker.py) so that a crash or a hang is a reported
failure with its input, not a dead test run.

Bounded in CI: VISCERA_FUZZ_EXAMPLES inputs (default 300, under a minute on
two cores), each within VISCERA_FUZZ_SECONDS_PER_INPUT (default 60 s). For a
long session raise both, e.g. VISCERA_FUZZ_EXAMPLES=20000. Inputs that broke
something are kept in fuzz_corpus/ (one MJCF file each, with what it found in
a comment) and replayed by test_corpus_inputs_hold.
"""

from __future__ import annotations

import json
import os
import pathlib
import re
import select
import subprocess
import sys
from xml.sax.saxutils import quoteattr

import pytest

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

import viscera  # noqa: E402

HERE = pathlib.Path(__file__).resolve().parent
CORPUS = HERE / "fuzz_corpus"
EXAMPLES = int(os.environ.get("VISCERA_FUZZ_EXAMPLES", "300"))
SECONDS_PER_INPUT = float(os.environ.get("VISCERA_FUZZ_SECONDS_PER_INPUT", "60"))
STEPS = 100

KEYS = viscera.attribute_names()
# each key's category from the plugin's table of keys (plugin/mujoco/keys.h): a new key is fuzzed by its kind
KINDS = {key: doc["kind"] for key, doc in viscera.attribute_docs().items()}
FLOAT_KEYS = tuple(key for key, kind in KINDS.items() if kind in ("real", "positive", "nonnegative"))
COUNT_KEYS = tuple(key for key, kind in KINDS.items() if kind == "count")
ENUMS = {key: viscera.allowed_values(key) for key, kind in KINDS.items() if kind == "choice"}
VECTORS = {key: int(viscera.attribute_docs()[key]["values"].split()[0]) for key, kind in KINDS.items()
           if kind == "vector"}
NAME_KEYS = ("grasp_sites", "grasp_joints")
# the custom keys have generators of their own below (a new one must get one)
assert {key for key, kind in KINDS.items() if kind == "custom"} == set(NAME_KEYS) | {"points", "pinned", "exclude"}, KINDS

GARBAGE = ("", " ", "abc", "1 2", "1e", "0x10", "--1", "1,5", "nan", "-nan", "inf", "-inf", "+inf", "1e999",
           "-1e999", "1e-999", "9" * 400, "0" * 50 + "1", "\u00e9", "1\t2", "true")
HUGE_COUNTS = ("1000001", "1000000000", "2147483647", "2147483648", "-2147483649", "9223372036854775808",
               "1e9", "10000001", "4.5", "-0")

# Malformed numbers: NaN, infinities, negatives, zero, subnormals, and magnitudes from 1e30 up (refused, or
# accepted as absurdly stiff or heavy materials that the divergence guard must hold). Finite lengths between
# 1e3 and 1e30 m are left out on purpose: they are accepted (up to the 2.1 GB bound) with up to millions of
# collision spheres, and stepping those 100 times takes minutes, a cost rather than a fault; the bound itself
# is tested in test_config.py.
numbers = st.one_of(
    st.floats(min_value=-1e3, max_value=1e3),
    st.floats(min_value=1e30, allow_infinity=True), st.floats(max_value=-1e30, allow_infinity=True),
    st.sampled_from((0.0, -0.0, -1.0, 1e-300, 1e300, 5e-324, float("nan"), float("inf"), float("-inf"))))
number_text = st.one_of(numbers.map(repr), st.sampled_from(GARBAGE))
count_text = st.one_of(st.integers(-10, 300).map(str), st.sampled_from(HUGE_COUNTS + GARBAGE))
vector_text = st.one_of(st.lists(numbers, min_size=0, max_size=8).map(lambda v: " ".join(map(repr, v))),
                        st.sampled_from(GARBAGE))


@st.composite
def polyline(draw) -> str:
    kind = draw(st.sampled_from(("small", "empty", "giant", "huge", "garbage")))
    if kind == "empty":
        return ""
    if kind == "garbage":
        return draw(st.sampled_from(GARBAGE))
    if kind == "giant":  # long but within the limit: 20000 vertices on a helix
        return " ".join(f"{0.05 * (i % 7):.4f} {0.05 * ((i // 7) % 7):.4f} {0.001 * i:.4f}" for i in range(20000))
    if kind == "huge":  # past the 300000-number limit
        return "0 0 0 " * 100001
    return " ".join(map(repr, draw(st.lists(numbers, min_size=0, max_size=45))))


FLOAT_RANGES = {"length": (0.05, 5.0), "mass": (1e-3, 10.0), "density": (100.0, 5000.0), "radius": (0.002, 0.05),
                "radius_min": (0.002, 0.05), "radius_max": (0.002, 0.05), "stretch_stiffness": (0.0, 1e4),
                "bend_stiffness": (0.0, 1e3), "global_stretch_stiffness": (0.0, 1e3), "damping": (0.0, 100.0),
                "contact_stiffness": (10.0, 1e5), "contact_damping": (0.0, 100.0), "friction": (0.0, 2.0),
                "self_friction": (0.0, 2.0), "mesentery_stiffness": (0.0, 1e3), "mesentery_length": (0.0, 0.5),
                "grasp_closed_below": (-1.0, 1.0), "grasp_reach": (1e-3, 0.1), "grasp_stiffness": (0.0, 1e5),
                "grasp_damping": (0.0, 100.0), "grasp_slip_force": (0.1, 100.0), "young_modulus": (1e3, 1e7),
                "wall_thickness": (1e-4, 0.01), "bending_rigidity": (0.0, 1.0),
                "tolerance": (0.03, 0.9)}  # finer tolerances take more points than a quick fuzz steps
# plausible ranges of the keys above; a key without one is drawn by its kind
KIND_RANGES = {"real": (-1.0, 1.0), "positive": (1e-3, 10.0), "nonnegative": (0.0, 10.0)}
COUNT_RANGES = {"control_points": (4, 300), "substeps": (1, 8), "collision_spheres": (2, 600),
                "samples_per_segment": (1, 8), "self_collision": (0, 1), "skin_rings_per_segment": (1, 8),
                "skin_ring_points": (3, 32), "mesentery_points": (1, 64), "divergence_retries": (0, 6)}


def count_range(key: str) -> tuple[int, int]:
    """The key's plausible counts: listed above, else the first few its table allows."""
    if key in COUNT_RANGES:
        return COUNT_RANGES[key]
    low, high = (int(x) for x in viscera.attribute_docs()[key]["values"].split(" to "))
    return low, min(high, low + 8)
plausible = st.floats(-1.0, 1.0).map(lambda x: f"{x:.4f}")


def valid_value(key: str, site_names: list[str], joint_names: list[str]):
    """Values a careful user might write: in range, yet anywhere in it (the stiff, the tiny, the fast)."""
    if key in FLOAT_KEYS:
        return st.floats(*FLOAT_RANGES.get(key, KIND_RANGES[KINDS[key]])).map(repr)
    if key in COUNT_KEYS:
        return st.integers(*count_range(key)).map(str)
    if key in ENUMS:
        return st.sampled_from(ENUMS[key])
    if key == "box":
        return st.tuples(*[st.floats(-1.0, 0.0)] * 3, *[st.floats(0.01, 1.0)] * 3).map(
            lambda v: " ".join(f"{x:.4f}" for x in v))
    if key in VECTORS:
        return st.lists(plausible, min_size=VECTORS[key], max_size=VECTORS[key]).map(" ".join)
    if key == "points":
        return st.lists(plausible, min_size=6, max_size=45).map(lambda v: " ".join(v[:len(v) - len(v) % 3]))
    if key == "pinned":
        return st.lists(st.integers(0, 3), max_size=3, unique=True).map(lambda v: " ".join(map(str, v)))
    if key == "exclude":  # the other instances' names (one may be itself, or absent: refused)
        return st.sampled_from(["gut0", "gut1", "gut2", "gut1 gut2"])
    names = site_names if key == "grasp_sites" else joint_names
    return st.lists(st.sampled_from(names or ["missing"]), min_size=1, max_size=1).map(" ".join)


def malformed_value(key: str, site_names: list[str], joint_names: list[str]):
    """NaN, Inf, wrong types, huge counts, empty and giant polylines, names that do not exist."""
    if key in FLOAT_KEYS:
        return number_text
    if key in COUNT_KEYS:
        return count_text
    if key in ENUMS:
        return st.sampled_from(GARBAGE)
    if key in VECTORS:
        return vector_text
    if key == "points":
        return polyline()
    if key == "pinned":
        return st.one_of(st.lists(st.integers(-5, 70), max_size=6).map(lambda v: " ".join(map(str, v))),
                         st.sampled_from(GARBAGE + HUGE_COUNTS))
    names = site_names if key == "grasp_sites" else joint_names
    return st.one_of(st.lists(st.sampled_from(names + ["missing", ""]), max_size=3).map(" ".join),
                     st.sampled_from(GARBAGE))


def config_value(key: str, site_names: list[str], joint_names: list[str]):
    valid = valid_value(key, site_names, joint_names)
    return st.one_of(valid, valid, valid, malformed_value(key, site_names, joint_names))  # 3 in 4 valid


@st.composite
def intestine_config(draw, site_names, joint_names) -> dict[str, str]:
    """A small valid base (so that stepping is quick) with random keys overridden, some unknown."""
    config = {"length": repr(draw(st.floats(0.05, 3.0))), "control_points": str(draw(st.integers(4, 60))),
              "shape": "line", "start": "0 0 0.3", "direction": "1 0 0.2"}
    for key in draw(st.lists(st.sampled_from(KEYS), max_size=5, unique=True)):
        config[key] = draw(config_value(key, site_names, joint_names))
    if draw(st.integers(0, 19)) == 7:  # now and then a key the plugin does not know
        config[draw(st.from_regex(r"[a-z_]{1,12}", fullmatch=True))] = draw(number_text)
    return config


SOLID_TYPES = ("box", "sphere", "capsule", "cylinder", "ellipsoid", "mesh")
STATIC_TYPES = SOLID_TYPES + ("plane", "hfield")  # MuJoCo allows these in the world body only


@st.composite
def geom_xml(draw, name: str, static: bool) -> str:
    kind = draw(st.sampled_from(STATIC_TYPES if static else SOLID_TYPES))
    size = " ".join(f"{draw(st.floats(0.01, 1.0)):.4f}" for _ in range(3))
    pos = " ".join(f"{draw(st.floats(-1.0, 1.0)):.4f}" for _ in range(3))
    euler = " ".join(f"{draw(st.floats(-180.0, 180.0)):.2f}" for _ in range(3))
    extra = {"mesh": ' mesh="rock"', "hfield": ' hfield="terrain"'}.get(kind, "")
    if kind in ("mesh", "hfield"):
        size = ""
    return (f'<geom name="{name}" type="{kind}" pos="{pos}" euler="{euler}"'
            + (f' size="{size}"' if size else "") + f"{extra} friction=\"{draw(st.floats(0.0, 2.0)):.3f}\"/>")


@st.composite
def scene(draw) -> tuple[str, list[str]]:
    """An MJCF scene: random option, static geoms, free bodies, a jawed tool, one to three intestines
    (touching: the later ones across the first, or inside it)."""
    timestep = draw(st.one_of(st.sampled_from((0.0005, 0.002, 0.01, 0.05)), st.floats(1e-4, 0.05)))
    integrator = draw(st.sampled_from(("Euler", "RK4", "implicit", "implicitfast")))
    gravity = " ".join(f"{draw(st.floats(-20.0, 20.0)):.3f}" for _ in range(3))
    bodies = [draw(geom_xml(f"static{i}", True)) for i in range(draw(st.integers(0, 3)))]
    for i in range(draw(st.integers(0, 2))):
        bodies.append(f'<body name="free{i}" pos="{draw(st.floats(-0.5, 0.5)):.3f} 0 {draw(st.floats(0.0, 1.0)):.3f}">'
                      f'<freejoint/>{draw(geom_xml(f"free{i}_geom", False))}</body>')
    sites, joints, actuators = [], [], ""
    if draw(st.booleans()):  # a jawed tool on a slide, driven by position actuators
        sites, joints = ["jaw_site"], ["jaw", "tool_slide"]
        bodies.append('<body name="tool" pos="0.2 0 0.5"><joint name="tool_slide" type="slide" axis="0 0 1"/>'
                      '<geom type="capsule" size="0.005 0.1" mass="0.1"/><site name="jaw_site" pos="0 0 -0.1"/>'
                      '<body name="jaw_body"><joint name="jaw" type="hinge" axis="1 0 0" range="0 0.7"/>'
                      '<geom type="sphere" size="0.005" mass="0.01" contype="0"/></body></body>')
        actuators = ('<actuator><position joint="tool_slide" kp="100" ctrlrange="-0.6 0.2"/>'
                     '<position joint="jaw" kp="1" ctrlrange="0 0.7"/></actuator>')
    instances, keys_set = [], []
    for i in range(draw(st.integers(1, 3))):  # several: they collide with each other
        config = draw(intestine_config(sites, joints))
        if i > 0 and draw(st.booleans()):  # across the first one, just above it (else right inside it)
            config["start"], config["direction"] = f"{0.1 * i:.2f} -0.2 {0.3 + 0.02 * i:.2f}", "0 1 0"
        keys_set.extend(config)
        entries = "".join(f"<config key={quoteattr(k)} value={quoteattr(v)}/>" for k, v in config.items())
        instances.append(f'<instance name="gut{i}">{entries}</instance>')
    sensor = ""
    if draw(st.booleans()):
        target = draw(st.sampled_from(["world"] + [f"free{i}" for i in range(2) if f'name="free{i}"' in "".join(bodies)]))
        sensor = f'<sensor><plugin instance="gut0" objtype="body" objname="{target}"/></sensor>'
    xml = (f'<mujoco><option timestep="{timestep!r}" integrator="{integrator}" gravity="{gravity}"/>'
           '<asset><mesh name="rock" vertex="0 0 0 0.1 0 0 0 0.1 0 0 0 0.1 0.08 0.08 0.08"/>'
           '<hfield name="terrain" nrow="4" ncol="5" size="0.5 0.4 0.1 0.02"/></asset>'
           f'<extension><plugin plugin="viscera.intestine">{"".join(instances)}</plugin></extension>'
           f'<worldbody>{"".join(bodies)}</worldbody>{actuators}{sensor}</mujoco>')
    return xml, keys_set


class Worker:
    """fuzz_worker.py in a subprocess; restarted after a crash or a hang."""

    def __init__(self):
        self.process = None

    def start(self):
        env = dict(os.environ, TQDM_DISABLE="1")
        self.process = subprocess.Popen([sys.executable, str(HERE / "fuzz_worker.py")], stdin=subprocess.PIPE,
                                        stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, env=env)
        ready = self._read(120.0)
        assert ready == {"outcome": "ready"}, ready

    def _read(self, timeout: float):
        ready, _, _ = select.select([self.process.stdout], [], [], timeout)
        if not ready:
            return {"outcome": "hang"}
        line = self.process.stdout.readline()
        if not line:
            return {"outcome": "crash", "exit": self.process.wait()}
        return json.loads(line)

    def run(self, xml: str) -> dict:
        if self.process is None or self.process.poll() is not None:
            self.start()
        try:
            self.process.stdin.write(json.dumps({"xml": xml, "steps": STEPS}) + "\n")
            self.process.stdin.flush()
        except BrokenPipeError:
            pass
        reply = self._read(SECONDS_PER_INPUT)
        if reply["outcome"] in ("hang", "crash"):
            self.stop()
        return reply

    def stop(self):
        if self.process is not None:
            self.process.kill()
            self.process.wait()
            self.process = None


@pytest.fixture(scope="module")
def worker():
    w = Worker()
    yield w
    w.stop()


def names_an_attribute(message: str, keys: list[str]) -> bool:
    """The refusal names an attribute the input set (MuJoCo names unknown keys 'plugin:key')."""
    quoted = set(re.findall(r"'([^']*)'", message))
    return bool(quoted & set(keys)) or any(q.startswith("plugin:") for q in quoted)


def check(worker: Worker, xml: str, keys: list[str]) -> str:
    """Run one input; returns its outcome ("refused" or "stepped") or fails with the input."""
    reply = worker.run(xml)
    outcome = reply["outcome"]
    shown = xml if len(xml) < 4000 else xml[:4000] + " ..."
    assert outcome in ("refused", "stepped"), f"{outcome} {reply} on\n{shown}"
    if outcome == "refused":
        assert names_an_attribute(reply["message"], keys), f"refusal names no attribute set: {reply['message']}\n{shown}"
        return "refused: " + (re.findall(r"'([^']*)'", reply["message"]) or ["?"])[0]
    else:
        assert not reply["non_finite"], f"non-finite {reply['non_finite']} after {STEPS} steps of\n{shown}"
    return outcome


@settings(max_examples=EXAMPLES, deadline=None, derandomize=not os.environ.get("VISCERA_FUZZ_RANDOM"),
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large, HealthCheck.large_base_example])
@given(scene())
def test_random_scenes_load_and_step_or_are_refused_by_name(worker, generated):
    xml, keys = generated
    hypothesis.event(check(worker, xml, keys))


def corpus() -> list[pathlib.Path]:
    return sorted(CORPUS.glob("*.xml"))


@pytest.mark.parametrize("path", corpus(), ids=lambda p: p.stem)
def test_corpus_inputs_hold(worker, path):
    """Inputs that once crashed, hung or were refused without a name, replayed."""
    xml = path.read_text()
    keys = re.findall(r'<config key="([^"]*)"', xml)
    check(worker, xml, keys)
