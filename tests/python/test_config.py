"""Bad config fails at model load with a ValueError naming the attribute and the value."""

import mujoco
import numpy as np
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
    ({"integrator": "euler"}, ["integrator", "euler", "symplectic_euler", "implicit"]),
    ({"mass_matrix": "diagonal"}, ["mass_matrix", "diagonal", "consistent", "lumped"]),
    ({"divergence_retries": "11"}, ["divergence_retries", "11"]),
    ({"divergence_retries": "-1"}, ["divergence_retries", "-1"]),
    ({"pinned": "0 250"}, ["pinned", "250"]),
    ({"pinned": "-251"}, ["pinned", "-251"]),
    ({"pinned": "a"}, ["pinned", "a"]),
    ({"shape": "spiral"}, ["shape", "spiral"]),
    ({"direction": "0 0 0"}, ["direction", "0 0 0"]),
    ({"start": "1 2"}, ["start", "1 2"]),
    ({"shape": "polyline"}, ["points"]),
    ({"shape": "polyline", "points": "0 0 0"}, ["points", "2 points"]),
    ({"shape": "polyline", "points": "0 0 0 1 0"}, ["points"]),
    ({"shape": "polyline", "points": "0 0 0 1 0 0"}, ["polyline", "points"]),  # 1 m < 4 m
    ({"shape": "control_points"}, ["points", "control_points"]),
    ({"shape": "control_points", "control_points": "4", "points": "0 0 0 1 0 0 2 0 0"}, ["points", "3 points", "4"]),
    ({"young_modulus": "-1"}, ["young_modulus", "-1"]),
    ({"young_modulus": "inf"}, ["young_modulus", "inf"]),
    ({"wall_thickness": "0.002"}, ["wall_thickness", "young_modulus"]),
    ({"young_modulus": "1e5", "wall_thickness": "0.02"}, ["wall_thickness", "0.02", "radius"]),
    ({"bending_rigidity": "-1"}, ["bending_rigidity", "-1"]),
    ({"clamped": "middle"}, ["clamped", "middle", "start"]),
    ({"clamped": "start", "bending_rigidity": "0.01", "shape": "control_points", "control_points": "4",
      "points": "0 0 0 0 0 0 0 0 0 1 0 0"}, ["clamped", "start", "tangent"]),
    ({"shape": "serpentine"}, ["box"]),
    ({"shape": "serpentine", "box": "0 0 0 0.3 0.1 0.05"}, ["box", "0 0 0 0.3 0.1 0.05", "cannot hold"]),
    ({"shape": "serpentine", "box": "1 0 0 0 1 1"}, ["box", "min"]),
    # sizes past the documented maxima: rejected, never an overflow or a hang
    ({"control_points": "2000000"}, ["control_points", "2000000", "at most"]),
    ({"samples_per_segment": "65"}, ["samples_per_segment", "65", "at most"]),
    ({"control_points": "500000", "samples_per_segment": "64"}, ["control_points", "samples_per_segment"]),
    ({"substeps": "100000000"}, ["substeps", "100000000", "at most"]),
    ({"collision_spheres": "99999999999"}, ["collision_spheres", "99999999999"]),
    ({"length": "10000", "radius": "1e-6"}, ["length", "radius", "collision_spheres"]),
    ({"density": "1e308"}, ["density", "non-finite mass"]),
    ({"shape": "serpentine", "radius": "1e-12", "collision_spheres": "100", "box": "0 0 0 1 1 1"}, ["box"]),
    # absurd resources: refused before any allocation, with the keys that ask for them
    ({"control_points": "1000000000"}, ["control_points", "1000000000", "at most"]),
    ({"control_points": "1000000", "samples_per_segment": "10"},
     ["control_points", "samples_per_segment", "collision_spheres", "GB", "more than the 2.1 GB"]),
    ({"collision_spheres": "10000000"}, ["collision_spheres", "10000000", "GB"]),
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


def test_misspelled_key_message_names_the_key_cleanly():
    """MuJoCo refuses the key before the plugin sees it, in its own words and with a stray quote
    ("unrecognized attribute 'plugin:lenght' for plugin viscera.intestine'"); load_error_message
    turns that into one clean sentence, the Python builder's own, with the nearest key."""
    import viscera
    from viscera.intestine import load_error_message
    xml = scene_xml().replace('<instance name="gut">', '<instance name="gut"><config key="lenght" value="4"/>')
    with pytest.raises(ValueError) as error:
        mujoco.MjModel.from_xml_string(xml)
    clean = "unknown config key 'lenght' for plugin viscera.intestine (did you mean 'length'?)"
    message = load_error_message(error.value)
    assert clean in message and "plugin:" not in message and "intestine'" not in message, message
    with pytest.raises(ValueError) as error:
        viscera.extension_xml("gut", lenght=4)
    assert str(error.value) == clean
    assert load_error_message("Error: repeated name 'gut'") == "Error: repeated name 'gut'"
    with pytest.raises(ValueError, match="unknown config key 'xyzzy' .*known keys: .*length"):
        viscera.extension_xml("gut", xyzzy=1)


def test_good_config_compiles_with_documented_defaults():
    import viscera
    model = mujoco.MjModel.from_xml_string(scene_xml())
    gut = viscera.intestine(model, "gut")
    assert gut.control_count == 250
    assert gut.rest_length == 4.0 and gut.radius == 0.0125
    assert gut.sphere_count == 321  # 4 m / 12.5 mm + 1: spaced one radius apart
    # positions, velocities, divergence and recovery counts, a wrench per body, friction state per
    # sphere, a rest record per control point, the gravity they were counted under, the wall's damage
    assert model.plugin_statenum[0] == 6 * 250 + 2 + 6 * model.nbody + 8 * 321 + 8 * 250 + 3 + 2 * 250


def test_a_million_control_points_load():
    """The largest accepted resolution loads and steps (its gather table was once built in O(n^2): hours)."""
    import viscera
    model = mujoco.MjModel.from_xml_string(scene_xml(control_points=1_000_000, length=4000.0))
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data)
    gut = viscera.intestine(model, "gut")
    assert gut.control_count == 1_000_000 and np.isfinite(gut.positions(data)).all()


def test_state_size_mismatch_fails_data_creation_instead_of_overflowing():
    """A model whose config no longer matches its state size (an MJB saved by another
    config, say) must not have its state overrun: MjData creation fails cleanly."""
    import viscera
    model = mujoco.MjModel.from_xml_string(scene_xml(control_points=20))
    raw = bytes(model.plugin_attr)
    start = raw.index(b"\x0020\x00") + 1  # the control_points value
    model.plugin_attr[start:start + 2] = np.frombuffer(b"90", dtype=np.uint8).view(model.plugin_attr.dtype)
    assert viscera.intestines(model)[0].control_count == 90
    with pytest.raises(Exception):
        mujoco.MjData(model)


def test_spline_points_rejects_bad_input():
    import viscera
    with pytest.raises(ValueError, match="4 control points"):
        viscera.spline_points(np.zeros((3, 3)), [0.5])
    with pytest.raises(ValueError, match="finite"):
        viscera.spline_points(np.zeros((5, 3)), [np.nan])


@pytest.mark.parametrize("key,expected", [("integrator", ("rk4", "symplectic_euler", "implicit", "leapfrog")),
                                          ("shape", ("line", "polyline", "serpentine", "control_points")),
                                          ("clamped", ("none", "start", "end", "both")),
                                          ("mass_matrix", ("consistent", "lumped"))])
def test_enumerated_keys_have_one_list_that_parsing_and_refusals_read(key, expected):
    """viscera.allowed_values reads the plugin's own list (tied to its enum): every name in it
    loads where the key's other needs are met, and a wrong name is refused with all of them."""
    import viscera
    assert viscera.allowed_values(key) == expected
    assert viscera.allowed_values("length") == ()
    with pytest.raises(ValueError) as refused:
        mujoco.MjModel.from_xml_string(scene_xml(**{key: "nonsense"}))
    message = str(refused.value)
    assert f"'{key}' = 'nonsense'" in message and all(name in message for name in expected)
    needs = {"polyline": {"points": "0 0 0 4 0 0"}, "serpentine": {"box": "-1 -1 0 1 1 1"},
             "control_points": {"points": " ".join(f"{x} 0 0" for x in np.linspace(0, 4, 250))},
             "start": {"bending_rigidity": "0.01"}, "end": {"bending_rigidity": "0.01"},
             "both": {"bending_rigidity": "0.01"}}
    for name in expected:
        mujoco.MjModel.from_xml_string(scene_xml(**{key: name}, **needs.get(name, {})))


def test_every_key_has_one_row_that_documents_it_and_names_its_unit_in_refusals():
    """The plugin's table of keys (plugin/mujoco/keys.h) is the key list MuJoCo is told, every row
    has a unit, a default and a meaning (docs/config.md's table is generated from it), and a
    refused number names the unit of its row."""
    import viscera
    docs = viscera.attribute_docs()
    assert tuple(docs) == viscera.attribute_names() and len(docs) == len(set(docs))
    assert all(row["unit"] and row["default"] and row["meaning"] for row in docs.values())
    for key in ("length", "contact_damping", "friction", "grasp_slip_force"):
        with pytest.raises(ValueError) as refused:
            mujoco.MjModel.from_xml_string(scene_xml(**{key: "-1"}))
        assert f"'{key}' = '-1'" in str(refused.value) and f"({docs[key]['unit']})" in str(refused.value)
