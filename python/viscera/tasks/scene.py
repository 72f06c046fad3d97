"""The tasks' scene: a cavity with the tools a task picks, and the episode a seed draws.

Two cavities ship (SCENES, by the name tasks are loaded with: viscera.tasks.load(name, seed,
scene=...)):
- "abdomen" (assets/scenes/abdomen.xml), the default: the box cavity with a 3 m bowel;
- "anatomical" (assets/scenes/abdomen_anatomical.xml): curved walls, a 5.06 m small bowel
  framed by the colon, a second intestine instance it touches.
Each scene file is the one source of its cavity and of each kind of tool: `compose` keeps its
walls, cameras, lights and intestines, removes its tools, and adds the task's tool set, each a
copy of the scene's tool of that kind (its trocar body, actuators and force sensor) renamed and
placed at a trocar. The tasks work on the scene's first intestine instance, the bowel (the small
bowel; the colon only frames it). Graspers are given to the bowel (`grasp_sites`,
`grasp_joints`), so their jaws hold what they close on.

`draw_episode` draws, from the task's RandomState, what differs between episodes (every range
and its source in docs/tasks.md):
- a settled start from the scene's bank (assets/scenes/abdomen_starts.npz, made by
  `python python/tools/settle.py --bank 24`: 24 layouts dropped into the cavity and settled;
  abdomen_anatomical_starts.npz likewise, the colon's settled points beside the bowel's);
- tissue parameters around the model's defaults: mass per length, the springs' stiffness,
  friction against the walls and tools and against itself, the mesentery's stiffness and depth;
- the table's tilt, 0 to 15 degrees in any direction (gravity turned by it);
the task then places its target on the settled bowel (`place_target`).
"""

from __future__ import annotations

import copy
import dataclasses
import functools
import math
import pathlib
import xml.etree.ElementTree as ElementTree

import numpy as np

from viscera import tissue
from viscera.intestine import default_stiffnesses, fixed_width_numbers

HERE = pathlib.Path(__file__).resolve()
SOURCE_SCENES = HERE.parents[3] / "assets" / "scenes"   # the source tree
PACKAGED_SCENES = HERE.parents[1] / "assets"            # the installed package's data


def scene_file(name: str) -> pathlib.Path:
    """A file of assets/scenes, from the source tree or the installed package's data."""
    source = SOURCE_SCENES / name
    return source if source.exists() else PACKAGED_SCENES / name


ABDOMEN = "abdomen.xml"
STARTS = "abdomen_starts.npz"


@dataclasses.dataclass(frozen=True)
class Scene:
    """A cavity the tasks load: its MJCF and bank of settled starts (files of assets/scenes), where
    targets are drawn and where the clearing gesture lays loops ((x low, x high), (y low, y high),
    m: on the floor inside the walls, and inside the colon where there is one), and the bowel's
    axis points observed by default (3 cm apart)."""

    name: str
    file: str
    starts: str
    target_region: tuple[tuple[float, float], tuple[float, float]]
    lay_region: tuple[tuple[float, float], tuple[float, float]]
    axis_samples: int


SCENES = {
    "abdomen": Scene("abdomen", ABDOMEN, STARTS, target_region=((-0.08, 0.08), (-0.07, 0.07)),
                     lay_region=((-0.12, 0.12), (-0.10, 0.10)), axis_samples=100),
    "anatomical": Scene("anatomical", "abdomen_anatomical.xml", "abdomen_anatomical_starts.npz",
                        target_region=((-0.07, 0.07), (-0.06, 0.07)), lay_region=((-0.09, 0.09), (-0.08, 0.09)),
                        axis_samples=170),
}
DEFAULT_SCENE = "abdomen"


def scene_named(name: str) -> Scene:
    """The scene called `name` (a key of SCENES); a clear error naming the known ones otherwise."""
    if not isinstance(name, str) or name not in SCENES:
        raise ValueError(f"scene = {name!r}: must be one of {sorted(SCENES)}")
    return SCENES[name]


TOOL_KINDS = ("grasper", "retractor")  # the abdomen's tools, by name, each the template of its kind
TROCARS = {"right": (0.07, -0.06, 0.15), "left": (-0.07, -0.06, 0.15)}  # m, on the anterior wall
G = 9.81  # m/s^2

# Tissue ranges, drawn uniformly: from the table of tissue parameters and their sources (viscera.tissue)
MASS_PER_LENGTH = tissue.drawn("mass_per_length")             # kg/m
STIFFNESS_SCALE = tissue.drawn("springs")                     # x the default stretch and bend springs (one factor)
FRICTION = tissue.drawn("friction_tools_walls")               # Coulomb, against walls and tools
SELF_FRICTION = tissue.drawn("friction_bowel_on_bowel")       # Coulomb, bowel on bowel
MESENTERY_STIFFNESS = tissue.drawn("mesentery_stiffness")     # N/m per tether
MESENTERY_LENGTH = tissue.drawn("mesentery_depth")            # m, the mesentery's depth
TILT_DEG = (0.0, 15.0)               # the table's tilt from level (not tissue: the operating table's)


@dataclasses.dataclass(frozen=True)
class Tool:
    """One tool of a task's scene: `name` (its bodies, joints, actuators and sensor are named
    after it), `kind` (grasper or retractor) and the trocar it enters by."""

    name: str
    kind: str
    trocar: str


@dataclasses.dataclass
class Episode:
    """What one seed draws (see draw_episode)."""

    start: int                 # index in the bank of settled starts
    control_points: np.ndarray  # m, (n, 3): the settled start
    mass: float                # kg, the whole intestine
    stiffness_scale: float     # x the default stretch and bend springs
    friction: float
    self_friction: float
    mesentery_stiffness: float  # N/m
    mesentery_length: float    # m
    tilt_deg: float            # the table's tilt
    tilt_azimuth_deg: float    # the direction it tilts towards (0: the patient's left, x)
    others: dict[str, np.ndarray] = dataclasses.field(default_factory=dict)  # m: the other intestines' start

    @property
    def gravity(self) -> np.ndarray:
        tilt, azimuth = math.radians(self.tilt_deg), math.radians(self.tilt_azimuth_deg)  # math: viscera.numerics
        return G * np.array([-math.sin(tilt) * math.cos(azimuth), -math.sin(tilt) * math.sin(azimuth), -math.cos(tilt)])


_STARTS_CACHE: dict[str, dict[str, np.ndarray]] = {}


def _bank(starts: str) -> dict[str, np.ndarray]:
    """A bank of settled starts by key (m, (K, n, 3) each), read once per process."""
    path = scene_file(starts)
    if str(path) not in _STARTS_CACHE:
        with np.load(path) as bank:
            _STARTS_CACHE[str(path)] = {key: bank[key] for key in bank.files}
    return _STARTS_CACHE[str(path)]


@functools.cache
def bowel_length(scene: str = DEFAULT_SCENE) -> float:
    """The rest length (m) of the scene's bowel (its first intestine instance), read once per process."""
    root = ElementTree.fromstring(scene_file(scene_named(scene).file).read_text())
    return float(next(c.get("value") for c in root.find("extension/plugin/instance").findall("config")
                      if c.get("key") == "length"))


def draw_episode(random: np.random.RandomState, length: float | None = None, scene: str = DEFAULT_SCENE) -> Episode:
    """Draw a start and the tissue and table for one episode of `scene` from `random` (the
    task's); `length` (m) is the bowel's (None: the scene's)."""
    bank = _bank(scene_named(scene).starts)
    starts = bank["control_points"]
    length = bowel_length(scene) if length is None else length
    index = int(random.randint(len(starts)))
    others = {key[:-len("_control_points")]: points[index] for key, points in bank.items()
              if key.endswith("_control_points")}
    return Episode(
        others=others,
        start=index, control_points=starts[index], mass=float(random.uniform(*MASS_PER_LENGTH)) * length,
        stiffness_scale=float(random.uniform(*STIFFNESS_SCALE)), friction=float(random.uniform(*FRICTION)),
        self_friction=float(random.uniform(*SELF_FRICTION)),
        mesentery_stiffness=float(random.uniform(*MESENTERY_STIFFNESS)),
        mesentery_length=float(random.uniform(*MESENTERY_LENGTH)),
        tilt_deg=float(random.uniform(*TILT_DEG)), tilt_azimuth_deg=float(random.uniform(0.0, 360.0)))


def tissue_config(length: float, mass: float, stiffness_scale: float, friction: float,
                  self_friction: float, mesentery_stiffness: float, mesentery_length: float) -> dict[str, str]:
    """The intestine config keys of one tissue draw (the ranges above) for a `length` m bowel of
    `mass` kg: the plugin's own default springs at this length scaled, friction and mesentery."""
    stretch, bend = default_stiffnesses(length)
    values = {"mass": mass, "stretch_stiffness": stretch * stiffness_scale,
              "bend_stiffness": bend * stiffness_scale, "friction": friction, "self_friction": self_friction,
              "mesentery_stiffness": mesentery_stiffness, "mesentery_length": mesentery_length}
    return {key: f"{value:.6g}" for key, value in values.items()}


def episode_config(episode: Episode, length: float) -> dict[str, str]:
    """The config keys of `episode`'s bowel (of rest length `length` m): its settled start and its
    tissue (tissue_config's keys, unrounded), every number at fixed width
    (viscera.intestine.fixed_width_numbers), so that a model compiled with one episode's keys
    takes another's in place (viscera.intestine.reconfigure) instead of compiling again."""
    stretch, bend = default_stiffnesses(length)
    values = {"points": episode.control_points, "mass": episode.mass,
              "stretch_stiffness": stretch * episode.stiffness_scale, "bend_stiffness": bend * episode.stiffness_scale,
              "friction": episode.friction, "self_friction": episode.self_friction,
              "mesentery_stiffness": episode.mesentery_stiffness, "mesentery_length": episode.mesentery_length}
    return {key: fixed_width_numbers(value) for key, value in values.items()}


def template_episode(scene: str = DEFAULT_SCENE) -> Episode:
    """The episode a task's model is compiled with before its first reset (the bank's first start,
    each tissue range's middle, a level table): every episode is then set in place over it."""
    bank = _bank(scene_named(scene).starts)
    middle = lambda bounds: 0.5 * (bounds[0] + bounds[1])  # noqa: E731
    return Episode(
        others={key[:-len("_control_points")]: points[0] for key, points in bank.items()
                if key.endswith("_control_points")},
        start=0, control_points=bank["control_points"][0], mass=middle(MASS_PER_LENGTH) * bowel_length(scene),
        stiffness_scale=middle(STIFFNESS_SCALE), friction=middle(FRICTION), self_friction=middle(SELF_FRICTION),
        mesentery_stiffness=middle(MESENTERY_STIFFNESS), mesentery_length=middle(MESENTERY_LENGTH),
        tilt_deg=0.0, tilt_azimuth_deg=0.0)


def tissue_corners(length: float = 3.0) -> dict[str, dict[str, str]]:
    """The ends of every tissue range above, as the intestine config keys of a `length` m bowel:
    2 x 2 x 2 corners named mass_springs_grip, light or heavy, soft or stiff (both spring scales),
    slippery (low friction, weak and shallow mesentery) or grippy (the other ends)."""
    corners = {}
    for mass_name, mass_per_length in zip(("light", "heavy"), MASS_PER_LENGTH):
        for spring_name, scale in zip(("soft", "stiff"), STIFFNESS_SCALE):
            for grip, end in (("slippery", 0), ("grippy", 1)):
                corners[f"{mass_name}_{spring_name}_{grip}"] = tissue_config(
                    length, mass_per_length * length, scale, FRICTION[end], SELF_FRICTION[end], MESENTERY_STIFFNESS[end],
                    MESENTERY_LENGTH[end])
    return corners


def with_intestine_config(xml: str, config: dict[str, str]) -> str:
    """`xml` (a scene with one intestine instance) with the intestine's config keys set (or, with
    None, removed)."""
    root = ElementTree.fromstring(xml)
    instance = root.find("extension/plugin/instance")
    for key, value in config.items():
        _config(instance, key, value)
    return ElementTree.tostring(root, encoding="unicode")


def _rename(element: ElementTree.Element, old: str, new: str) -> None:
    """Every name-like attribute of `element` and below that starts with `old`, renamed to `new`."""
    for node in element.iter():
        for attribute in ("name", "joint", "site", "objname", "body"):
            value = node.get(attribute)
            if value is not None and value.startswith(old):
                node.set(attribute, new + value[len(old):])


def _config(instance: ElementTree.Element, key: str, value: str | None) -> None:
    """Set (or with None remove) the intestine's config `key`."""
    for node in instance.findall("config"):
        if node.get("key") == key:
            if value is None:
                instance.remove(node)
            else:
                node.set("value", value)
            return
    if value is not None:
        ElementTree.SubElement(instance, "config", key=key, value=value)


def _numbers(values) -> str:
    return " ".join(f"{float(x):.6g}" for x in np.ravel(values))


def compose(tools: tuple[Tool, ...], episode: Episode | None = None, target: tuple | None = None,
            intestine_config: dict[str, str] | None = None, target_half: tuple | None = None,
            show_target: bool = True, scene: str = DEFAULT_SCENE) -> str:
    """The MJCF of `scene` (a key of SCENES) with `tools` in place of its own, the intestines and
    the gravity of `episode` (None: the shipped scene's), the target site at `target` ((x, y) m
    on the posterior wall, or (x, y, z) m; None: where the scene has it) of half sizes
    `target_half` ((x, y) m; None: the scene's) and extra config keys of the bowel (its first
    intestine); a task without a target draws none (`show_target` False: the site stays,
    invisible)."""
    root = ElementTree.fromstring(scene_file(scene_named(scene).file).read_text())
    worldbody, actuators, sensors = root.find("worldbody"), root.find("actuator"), root.find("sensor")
    templates = {}
    for kind in TOOL_KINDS:
        body = worldbody.find(f"body[@name='{kind}_trocar']")
        templates[kind] = (body, [a for a in actuators if a.get("name", "").startswith(kind + "_")],
                           [s for s in sensors if s.get("name") == f"{kind}_force"])
        worldbody.remove(body)
        for node in templates[kind][1]:
            actuators.remove(node)
        for node in templates[kind][2]:
            sensors.remove(node)
    for tool in tools:
        body, tool_actuators, tool_sensors = templates[tool.kind]
        for node, parent in [(body, worldbody)] + [(a, actuators) for a in tool_actuators] + [
                (s, sensors) for s in tool_sensors]:
            added = copy.deepcopy(node)
            _rename(added, tool.kind, tool.name)
            if node is body:
                added.set("pos", _numbers(TROCARS[tool.trocar]))
            parent.append(added)
    instance = root.find("extension/plugin/instance")
    graspers = [tool.name for tool in tools if tool.kind == "grasper"]
    _config(instance, "grasp_sites", " ".join(f"{name}_tip" for name in graspers) or None)
    _config(instance, "grasp_joints", " ".join(f"{name}_jaw" for name in graspers) or None)
    if episode is not None:
        root.find("option").set("gravity", fixed_width_numbers(episode.gravity))  # as start_episode sets it
        for other in root.findall("extension/plugin/instance")[1:]:
            if other.get("name") in episode.others:
                _config(other, "shape", "control_points")
                _config(other, "points", fixed_width_numbers(episode.others[other.get("name")]))
        length = float(next(c.get("value") for c in instance.findall("config") if c.get("key") == "length"))
        for key, value in episode_config(episode, length).items():
            _config(instance, key, value)
    for key, value in (intestine_config or {}).items():
        _config(instance, key, value)
    site = worldbody.find("site[@name='target_area']")
    if target is not None:
        z = float(target[2]) if len(target) > 2 else float(site.get("pos").split()[2])
        site.set("pos", _numbers((target[0], target[1], z)))
    if not show_target:
        site.set("rgba", "0 0 0 0")
    if target_half is not None and episode is not None:
        site.set("size", _numbers((target_half[0], target_half[1], float(site.get("size").split()[2]))))
    return ElementTree.tostring(root, encoding="unicode")


def place_target(random: np.random.RandomState, coverage_at, loops_at, region=((-0.08, 0.08), (-0.07, 0.07)),
                 covered_at_least: float = 0.6, candidates: int = 16) -> tuple[float, float]:
    """A target centre (x, y, m) in `region` (the middle of the posterior wall, clear of the
    flanks): of `candidates` draws, those the bowel covers by at least `covered_at_least`
    (coverage_at(x, y) gives the covered fraction), the one under the fewest loops (loops_at(x, y)
    counts the stretches of the axis over it; the first of equals). A target under a whole pile
    is as real, but no gesture clears it in an episode. The most covered draw if none is covered
    enough."""
    draws = [(float(random.uniform(*region[0])), float(random.uniform(*region[1]))) for _ in range(candidates)]
    covered = [coverage_at(*centre) for centre in draws]
    eligible = [i for i, c in enumerate(covered) if c >= covered_at_least]
    if not eligible:
        return draws[int(np.argmax(covered))]
    loops = [loops_at(*draws[i]) for i in eligible]
    return draws[eligible[int(np.argmin(loops))]]
