"""Bad config fails at model load with a ValueError naming the attribute and the value."""

import mujoco
import pytest

from conftest import scene_xml

BAD = [
    # (config, words the message must contain)
    ({"length": "-1"}, ["length", "-1"]),
    ({"length": "0"}, ["length", "0"]),
    ({"length": "nan"}, ["length", "nan"]),
    ({"length": "inf"}, ["length", "inf"]),
    ({"length": "four"}, ["length", "four"]),
    ({"mass": "0"}, ["mass", "0"]),
    ({"mass": "-2"}, ["mass", "-2"]),
    ({"mass": "1", "density": "1000"}, ["mass", "density"]),
    ({"density": "-5"}, ["density", "-5"]),
    ({"radius": "0"}, ["radius", "0"]),
    ({"radius": "-0.01"}, ["radius", "-0.01"]),
    ({"radius_min": "0.02", "radius_max": "0.01"}, ["radius_min", "radius_max"]),
    ({"stretch_stiffness": "-1"}, ["stretch_stiffness", "-1"]),
    ({"bend_stiffness": "-1"}, ["bend_stiffness", "-1"]),
    ({"global_stretch_stiffness": "NaN"}, ["global_stretch_stiffness", "NaN"]),
    ({"stretch_stiffness": "0", "bend_stiffness": "0", "global_stretch_stiffness": "0"}, ["stretch_stiffness"]),
    ({"damping": "-0.5"}, ["damping", "-0.5"]),
    ({"contact_stiffness": "0"}, ["contact_stiffness", "0"]),
    ({"contact_damping": "-1"}, ["contact_damping", "-1"]),
    ({"control_points": "3"}, ["control_points", "3"]),
    ({"control_points": "12.5"}, ["control_points", "12.5"]),
    ({"substeps": "0"}, ["substeps", "0"]),
    ({"collision_spheres": "1"}, ["collision_spheres", "1"]),
    ({"integrator": "euler"}, ["integrator", "euler"]),
    ({"pinned": "0 250"}, ["pinned", "250"]),
    ({"pinned": "-1"}, ["pinned", "-1"]),
    ({"pinned": "a"}, ["pinned", "a"]),
    ({"shape": "spiral"}, ["shape", "spiral"]),
    ({"direction": "0 0 0"}, ["direction", "0 0 0"]),
    ({"start": "1 2"}, ["start", "1 2"]),
    ({"shape": "polyline"}, ["points"]),
    ({"shape": "polyline", "points": "0 0 0"}, ["points", "2 points"]),
    ({"shape": "polyline", "points": "0 0 0 1 0"}, ["points"]),
    ({"shape": "polyline", "points": "0 0 0 1 0 0"}, ["polyline", "points"]),  # 1 m < 4 m
    ({"shape": "serpentine"}, ["box"]),
    ({"shape": "serpentine", "box": "0 0 0 0.3 0.1 0.05"}, ["box", "0 0 0 0.3 0.1 0.05", "cannot hold"]),
    ({"shape": "serpentine", "box": "1 0 0 0 1 1"}, ["box", "min"]),
]


@pytest.mark.parametrize("config,words", BAD, ids=[",".join(f"{k}={v}" for k, v in c.items()) for c, _ in BAD])
def test_bad_config_is_a_clear_value_error(config, words):
    xml = scene_xml(**config)
    with pytest.raises(ValueError) as error:
        mujoco.MjModel.from_xml_string(xml)
    message = str(error.value)
    for word in words:
        assert word in message, message


def test_unknown_key_names_the_key():
    xml = scene_xml().replace('<instance name="gut">', '<instance name="gut"><config key="lenght" value="4"/>')
    with pytest.raises(ValueError, match="lenght"):
        mujoco.MjModel.from_xml_string(xml)


def test_python_builder_rejects_unknown_keys():
    import viscera
    with pytest.raises(ValueError, match="lenght"):
        viscera.extension_xml("gut", lenght=4)


def test_good_config_compiles_with_documented_defaults():
    import viscera
    model = mujoco.MjModel.from_xml_string(scene_xml())
    gut = viscera.intestine(model, "gut")
    assert gut.control_count == 250
    assert gut.rest_length == 4.0 and gut.radius == 0.0125
    assert gut.sphere_count == 161  # 4 m / 25 mm + 1: neighbours touch
    assert model.plugin_statenum[0] == 6 * 250 + 1
