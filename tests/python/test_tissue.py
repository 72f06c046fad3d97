"""The table of tissue parameters (viscera.tissue) is what the plugin, the scene and the tasks use."""

import xml.etree.ElementTree as ElementTree

import numpy as np
import pytest

import viscera
from viscera import tissue
from viscera.tasks import scene

PLUGIN_DEFAULTS = {"grasp_friction": "grasp_friction", "grasp_slip_force": "grasp_slip_force",
                   "perforation_pinch": "damage_perforation_pinch", "damage_force_time": "damage_force_time",
                   "tear_strain": "damage_tear_strain", "damping": "damping"}
SCENE_VALUES = {"mesentery_stiffness": ("mesentery_stiffness", 1.0), "mesentery_depth": ("mesentery_length", 1.0),
                "friction_tools_walls": ("friction", 1.0), "radius": ("radius", 1e3)}


@pytest.mark.parametrize("name", sorted(PLUGIN_DEFAULTS))
def test_the_plugins_defaults_are_the_tables(name):
    assert float(viscera.attribute_docs()[PLUGIN_DEFAULTS[name]]["default"]) == tissue.parameter(name).value


def test_the_box_abdomens_values_are_the_tables():
    root = ElementTree.fromstring(scene.scene_file("abdomen.xml").read_text())
    config = {c.get("key"): c.get("value") for c in root.find("extension/plugin/instance").findall("config")}
    docs = viscera.attribute_docs()
    for name, (key, scale) in SCENE_VALUES.items():
        value = float(config.get(key, docs[key]["default"])) * scale
        assert value == pytest.approx(tissue.parameter(name).value), name


def test_every_episode_draws_within_the_tables_ranges():
    random = np.random.RandomState(0)
    length = scene.bowel_length()
    for _ in range(200):
        episode = scene.draw_episode(random)
        lo, hi = tissue.drawn("mass_per_length")
        assert lo <= episode.mass / length <= hi
        for field, name in (("stiffness_scale", "springs"), ("friction", "friction_tools_walls"),
                            ("self_friction", "friction_bowel_on_bowel"), ("mesentery_stiffness", "mesentery_stiffness"),
                            ("mesentery_length", "mesentery_depth")):
            lo, hi = tissue.drawn(name)
            assert lo <= getattr(episode, field) <= hi, field


def test_every_row_says_what_was_measured_and_what_chose_it():
    for p in tissue.PARAMETERS:
        assert p.measured and p.chosen_by and p.unit, p.name
        assert p.drawn is None or p.drawn[0] < p.drawn[1]
    with pytest.raises(KeyError, match="no tissue parameter 'spleen'"):
        tissue.parameter("spleen")
    with pytest.raises(ValueError, match="not drawn"):
        tissue.drawn("radius")
