"""Intestine instances of one model collide with each other: one dropped across another comes to rest
on top of it, the forces between them are equal and opposite, a pair can be excluded, and copies,
pickles and threads step two touching instances bit for bit."""

import pickle

import mujoco
import numpy as np
import pytest
from mujoco import rollout

import viscera
from viscera.scale.batch import serial_step

FULLPHYSICS = mujoco.mjtState.mjSTATE_FULLPHYSICS


def instance_xml(name: str, **config) -> str:
    """One <instance> element (viscera.extension_xml writes a whole <extension>)."""
    whole = viscera.extension_xml(name, **config)
    return "<instance" + whole.split("<instance", 1)[1].split("</instance>", 1)[0] + "</instance>"


def model_xml(instances: list[str], body: str = '<geom type="plane" size="3 3 0.1"/>', options: str = "") -> str:
    return (f'<mujoco><option timestep="0.002" {options}/><extension><plugin plugin="viscera.intestine">'
            + "".join(instances) + f"</plugin></extension><worldbody>{body}</worldbody></mujoco>")


def crossing(top_first: bool, top_radius=0.01, bottom_radius=0.0125, **top_config):
    """A 1 m, 30-point tube on the floor along x and another across it along y, 0.3 m up."""
    bottom = instance_xml("bottom", length=1.0, control_points=30, radius=bottom_radius, shape="line",
                          start=[-0.5, 0, bottom_radius], direction=[1, 0, 0])
    top = instance_xml("top", length=1.0, control_points=30, radius=top_radius, shape="line",
                       start=[0, -0.5, 0.3], direction=[0, 1, 0], **top_config)
    model = mujoco.MjModel.from_xml_string(model_xml([top, bottom] if top_first else [bottom, top]))
    return model, mujoco.MjData(model), viscera.intestine(model, "bottom"), viscera.intestine(model, "top")


@pytest.mark.parametrize("top_first", [False, True], ids=["dropped one second", "dropped one first"])
def test_a_tube_dropped_across_another_rests_on_top(top_first):
    """The axes never come closer than 90 % of the sum of the radii, at any step; the top one's
    middle comes to rest at the bottom one's diameter plus its own radius (within 10 %)."""
    r_top, r_bottom = 0.01, 0.0125
    model, data, bottom, top = crossing(top_first, r_top, r_bottom)
    closest = np.inf
    while data.time < 3.0:
        mujoco.mj_step(model, data)
        a, b = bottom.axis_points(data, 300), top.axis_points(data, 300)
        closest = min(closest, np.min(np.linalg.norm(a[:, None] - b[None], axis=2)))
    assert closest >= 0.9 * (r_top + r_bottom)
    middle = top.axis_points(data, 201)[100]
    assert middle[2] == pytest.approx(2 * r_bottom + r_top, rel=0.1)
    assert bottom.axis_points(data, 201)[100][2] == pytest.approx(r_bottom, rel=0.1)
    for gut in (bottom, top):
        assert gut.recovery_count(data) == 0 and gut.divergence_count(data) == 0


def test_an_excluded_pair_passes_through():
    """'exclude' on either instance: the top tube falls through to the floor, as MuJoCo's <exclude>."""
    model, data, bottom, top = crossing(False, exclude="bottom")
    while data.time < 2.0:
        mujoco.mj_step(model, data)
    assert top.axis_points(data, 201)[100][2] == pytest.approx(0.01, rel=0.1)


def curve_momentum(gut, data, mass):
    """Momentum (N s) of a rod with the lumped mass matrix: sum_k m_k v_k with m_k = m integral b_k,
    that is m times the integral over the abscissa of the axis velocity (trapezoids: exact to 1e-10
    on 20000 intervals of a cubic spline)."""
    s = np.linspace(0.0, 1.0, 20001)
    return mass * np.trapezoid(viscera.spline_points(gut.velocities(data), s), s, axis=0)


def test_forces_between_instances_are_equal_and_opposite():
    """Weightless, nothing else to touch: one tube thrown across another. Each changes momentum,
    and the sum of the two stays what it was: the impulse one gets is the one the other gives."""
    a = instance_xml("a", length=1.0, control_points=30, shape="line", start=[-0.5, 0, 0], direction=[1, 0, 0],
                     damping=0)
    b = instance_xml("b", length=1.0, control_points=30, shape="line", start=[0.1, -0.5, 0.05],
                     direction=[0, 1, 0], damping=0, self_friction=0.6)
    model = mujoco.MjModel.from_xml_string(model_xml([a, b], body="", options='gravity="0 0 0"'))
    data = mujoco.MjData(model)
    ga, gb = viscera.intestine(model, "a"), viscera.intestine(model, "b")
    gb.velocities(data)[:] = [0.3, 0.2, -1.0]  # m/s: down onto a, sliding along and across it
    before = curve_momentum(ga, data, ga.mass) + curve_momentum(gb, data, gb.mass)
    while data.time < 0.3:
        mujoco.mj_step(model, data)
    exchanged = curve_momentum(ga, data, ga.mass)
    after = exchanged + curve_momentum(gb, data, gb.mass)
    assert np.linalg.norm(exchanged) > 0.05 * np.linalg.norm(before)  # they did collide
    np.testing.assert_allclose(after, before, atol=1e-9 * np.linalg.norm(before))


def test_copies_pickles_and_threads_step_touching_instances_bit_for_bit():
    model, data, bottom, top = crossing(False)
    for _ in range(150):  # the top tube lands on the bottom one at about 0.22 s
        mujoco.mj_step(model, data)
    copied = mujoco.MjData(model)
    mujoco.mj_copyData(copied, model, data)
    pickled = pickle.loads(pickle.dumps(data))
    for twin in (data, copied, pickled):
        for _ in range(100):
            mujoco.mj_step(model, twin)
    for twin in (copied, pickled):
        np.testing.assert_array_equal(twin.plugin_state, data.plugin_state)
    # rollout on two threads from three starts (the top tube landing, 0, 10 and 20 steps apart),
    # against serial stepping
    initial = np.empty((3, mujoco.mj_stateSize(model, FULLPHYSICS)))
    for row in initial:
        mujoco.mj_getState(model, copied, row, FULLPHYSICS)
        for _ in range(10):
            mujoco.mj_step(model, copied)
    assert not np.array_equal(initial[0], initial[1])
    controls = np.zeros((3, 80, model.nu))
    threaded, _ = rollout.rollout(model, [mujoco.MjData(model) for _ in range(2)], initial, controls)
    np.testing.assert_array_equal(threaded, serial_step(model, initial, controls).state)


@pytest.mark.parametrize("value, words", [("nowhere", ["exclude", "nowhere", "no plugin instance named"]),
                                          ("top", ["exclude", "top", "itself"])])
def test_a_bad_exclude_is_refused_at_load(value, words):
    top = instance_xml("top", length=1.0, control_points=10, exclude=value)
    with pytest.raises(ValueError) as error:
        mujoco.MjModel.from_xml_string(model_xml([top]))
    for word in words:
        assert word in str(error.value)


def test_each_instance_senses_its_own_force_on_a_body():
    """A tube draped over a force-measured bar, a second draped over the first: the bar carries
    both, through the first, and the first's sensor reads both weights, the second's none."""
    under = instance_xml("under", length=1.0, control_points=40, shape="line", start=[-0.5, 0, 1.0225],
                         direction=[1, 0, 0], damping=3, self_friction=0.8)
    over = instance_xml("over", length=0.8, control_points=32, shape="line", start=[-0.4, 0, 1.0475],
                        direction=[1, 0, 0], damping=3, self_friction=0.8)
    bar = '<body name="bar" pos="0 0 1"><geom type="capsule" size="0.01 0.2" euler="90 0 0"/></body>'
    xml = model_xml([under, over], body=bar).replace(
        "</mujoco>", '<sensor><plugin name="under_force" instance="under" objtype="body" objname="bar"/>'
                     '<plugin name="over_force" instance="over" objtype="body" objname="bar"/></sensor></mujoco>')
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    under_gut, over_gut = viscera.intestine(model, "under"), viscera.intestine(model, "over")
    while data.time < 3.0:  # settled (a stack of two tubes on a bar is unstable: it rolls off at 3.7 s)
        mujoco.mj_step(model, data)
    assert over_gut.positions(data)[:, 2].min() < 0.85  # draped over the other ...
    on_top = over_gut.axis_points(data, 201)[100] - under_gut.axis_points(data, 201)[100]
    assert abs(on_top[1]) < 0.005 and on_top[2] == pytest.approx(0.025, rel=0.1)  # ... still on top of it
    G = 9.81
    assert data.sensor("under_force").data[2] == pytest.approx(-(under_gut.mass + over_gut.mass) * G, rel=0.02)
    assert abs(data.sensor("over_force").data[2]) < 0.01 * over_gut.mass * G


def test_the_shipped_scene_of_two_intestines_settles_one_across_the_other():
    """assets/scenes/together.xml: the colon, dropped across the small bowel, rests partly on it
    (its axis one small-bowel diameter plus its radius up) and partly on the floor, no part of either
    sunk into the other or the floor by more than a tenth of the radii, without a recovery."""
    import pathlib
    model = mujoco.MjModel.from_xml_path(str(pathlib.Path(__file__).resolve().parents[2] / "assets" / "scenes" /
                                             "together.xml"))
    data = mujoco.MjData(model)
    bowel, colon = viscera.intestine(model, "small_bowel"), viscera.intestine(model, "colon")
    closest = np.inf
    while data.time < 3.0:
        mujoco.mj_step(model, data)
        a, b = bowel.axis_points(data, 400), colon.axis_points(data, 200)
        closest = min(closest, np.min(np.linalg.norm(a[:, None] - b[None], axis=2)))
    assert closest >= 0.9 * (bowel.radius + colon.radius)
    heights = colon.axis_points(data, 200)[:, 2]
    assert heights.max() == pytest.approx(2 * bowel.radius + colon.radius, rel=0.1)
    assert heights.min() >= 0.9 * colon.radius
    for gut in (bowel, colon):
        assert gut.recovery_count(data) == 0 and gut.divergence_count(data) == 0


def test_a_tube_resting_on_another_sleeps_and_wakes_when_the_lower_one_moves():
    """The points the lower instance loads sleep once both rest (a load from a partner at rest, as a
    resting geom's, wakes nothing), and wake when the lower one's spheres under them move, as a
    moving geom wakes what it touches (docs/model.md#intestines-together)."""
    bottom = instance_xml("bottom", length=1.0, control_points=30, radius=0.0125, shape="line",
                          start=[-0.5, 0, 0.0125], direction=[1, 0, 0], sleep=1, damping=5)
    top = instance_xml("top", length=1.0, control_points=30, radius=0.01, shape="line",
                       start=[0, -0.5, 0.05], direction=[0, 1, 0], sleep=1, damping=5)
    model = mujoco.MjModel.from_xml_string(model_xml([bottom, top]))
    data = mujoco.MjData(model)
    lower, upper = viscera.intestine(model, "bottom"), viscera.intestine(model, "top")
    while data.time < 4.0:
        mujoco.mj_step(model, data)
    # the top tube's middle lies on the bottom one: loaded, and asleep with the rest of it
    middle = upper.axis_points(data, 201)[100]
    assert middle[2] == pytest.approx(2 * 0.0125 + 0.01, rel=0.1)
    assert np.all(upper.asleep(data)) and np.all(lower.asleep(data))
    # the bottom tube's middle kicked upwards: the top one's points over it wake
    state = data.plugin_state[model.plugin_stateadr[lower.instance]:]
    velocities = state[lower.layout["velocities"]].reshape(-1, 3)
    velocities[12:18, 2] = 0.05
    rest = state[lower.layout["rest"]].reshape(lower.control_count, -1)
    rest[12:18, 0] = 0.0  # awake (its rest starts over)
    for _ in range(5):
        mujoco.mj_step(model, data)
    woken = ~np.asarray(upper.asleep(data), bool)
    assert woken[13:17].all() and not woken[:5].any()
