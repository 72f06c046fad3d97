"""`tolerance` chooses the resolution: rods the project does not ship, at 1e-2 and 1e-3, come within
it against their analytic references, the coarser model costs less, what cannot be met is refused at
load with the value and the limit, and the table the core reads is the committed study's."""

import json
import pathlib
import re

import mujoco
import numpy as np
import pytest

import viscera

from conftest import compile_scene

ROOT = pathlib.Path(__file__).resolve().parents[2]
G = 9.81


def relax(model, data, seconds):
    while data.time < seconds:
        mujoco.mj_step(model, data)


def work(model, gut):
    """Control points x substeps per step: the rod's integration work, as the resolution sets it."""
    return gut.control_count * gut.stability()["substeps"]


def cantilever(tolerance):
    """0.8 m, 9 mm solid section, density 1100 kg/m^3, clamped, under its own weight; E for a 1 %
    tip deflection. Reference: w L^4 / (8 EI)."""
    length, radius, density = 0.8, 0.009, 1100.0
    mu = density * np.pi * radius**2
    rigidity = mu * G * length**4 / (8.0 * 0.01 * length)
    young = rigidity / (np.pi * radius**4 / 4.0)
    model, data, gut = compile_scene(options='timestep="0.001"', length=length, radius=radius, density=density,
                                     young_modulus=young, damping=30, clamped="start", shape="line",
                                     direction=[1, 0, 0], tolerance=tolerance)
    relax(model, data, 0.8)
    deflection = -gut.axis_points(data, 2)[-1][2]
    return deflection / (mu * G * length**4 / (8.0 * rigidity)) - 1.0, work(model, gut), gut


def catenary(tolerance):
    """2.5 m of a stiff material without bending rigidity (E = 1e8 Pa, 10 mm), ends pinned 2 m apart,
    nothing to touch. Reference: the sag a (cosh(D / 2a) - 1), L = 2a sinh(D / 2a)."""
    length, span = 2.5, 2.0
    low, high = 0.05, 100.0
    for _ in range(200):  # a by bisection: the chain's length falls as a grows
        a = 0.5 * (low + high)
        low, high = (a, high) if 2 * a * np.sinh(span / (2 * a)) > length else (low, a)
    sag = a * (np.cosh(span / (2 * a)) - 1.0)
    depth = np.sqrt((length / 2) ** 2 - (span / 2) ** 2)
    model, data, gut = compile_scene(options='timestep="0.001"', length=length, radius=0.01, young_modulus=1e8,
                                     bending_rigidity=0, damping=4, self_collision=0, shape="polyline",
                                     points=[-span / 2, 0, 0, 0, 0, -depth, span / 2, 0, 0], pinned=[0, -1],
                                     tolerance=tolerance)
    relax(model, data, 6.0)
    measured = -gut.axis_points(data, 20001)[:, 2].min()
    return measured / sag - 1.0, work(model, gut), gut


@pytest.mark.parametrize("case", [cantilever, catenary])
def test_a_rod_not_shipped_comes_within_its_tolerance_and_the_coarser_costs_less(case):
    coarse_error, coarse_work, coarse = case(1e-2)
    fine_error, fine_work, fine = case(1e-3)
    assert abs(coarse_error) <= 1e-2
    assert abs(fine_error) <= 1e-3
    assert fine.control_count > coarse.control_count
    assert fine_work > 2 * coarse_work


def test_an_explicit_key_wins_over_the_tolerance():
    _, _, chosen = compile_scene(length=1.0, tolerance=1e-3)
    _, _, given = compile_scene(length=1.0, tolerance=1e-3, control_points=30, samples_per_segment=2)
    assert chosen.control_count > 30 and chosen.samples_per_segment == 1
    assert (given.control_count, given.samples_per_segment) == (30, 2)
    assert given.sphere_count == chosen.sphere_count  # still the tolerance's


def test_spheres_close_where_the_tube_can_touch_and_one_radius_apart_where_not():
    radius = 0.0125
    _, _, touching = compile_scene(length=1.0, radius=radius, tolerance=1e-3)  # self-collision on
    _, _, alone = compile_scene(length=1.0, radius=radius, tolerance=1e-3, self_collision=0)
    spacing = 1.0 / (touching.sphere_count - 1)
    assert spacing**2 / (8 * radius) <= 1e-3 * radius  # the chain's sagitta within the tolerance
    assert alone.sphere_count == int(np.ceil(1.0 / radius)) + 1


@pytest.mark.parametrize("config, words", [
    ({"tolerance": 1e-6}, ["tolerance", "1e-06", "below", "validation"]),
    ({"tolerance": 1.5}, ["tolerance", "1.5", "below 1"]),
    ({"tolerance": -0.1}, ["tolerance", "-0.1", "positive"]),
    ({"tolerance": 1e-2, "length": 1e5}, ["tolerance", "0.01", "control points", "limit 1000000"]),
    ({"tolerance": 1e-3, "integrator": "implicit", "young_modulus": 1e9},
     ["tolerance", "0.001", "substeps", "limit 1024"]),
])
def test_a_tolerance_that_cannot_be_met_is_refused_at_load_naming_value_and_limit(config, words):
    with pytest.raises(ValueError) as error:
        compile_scene(**config)
    for word in words:
        assert word in str(error.value)


def test_pinned_indices_count_from_the_end():
    model, data, gut = compile_scene(length=1.0, control_points=12, pinned=[0, -1], self_collision=0)
    start = gut.positions(data).copy()
    relax(model, data, 0.2)
    moved = np.linalg.norm(gut.positions(data) - start, axis=1)
    assert moved[0] == 0 and moved[-1] == 0 and moved[5] > 1e-3


def test_the_table_the_core_reads_is_the_committed_studys():
    """plugin/core/src/vsc_tolerance_table.h holds docs/validation/tolerance.json's envelopes."""
    header = (ROOT / "plugin" / "core" / "src" / "vsc_tolerance_table.h").read_text()
    study = json.loads((ROOT / "docs" / "validation" / "tolerance.json").read_text())
    for group, rows in study["envelopes"].items():
        block = re.search(rf"vsc_tolerance_envelope_{group}\[\]\[2\] = \{{(.*?)\}};", header, re.S).group(1)
        numbers = [[float(x) for x in pair] for pair in re.findall(r"\{([^,]+), ([^}]+)\}", block)]
        assert np.ravel(numbers) == pytest.approx(np.ravel(rows), rel=1e-3)
        # the envelope bounds every case of its group at 1 sample per segment, from its N on
        for errors in study["convergence"][group]["1"].values():
            for n, bound in rows:
                assert max(e for m, e in errors.items() if int(m) >= n) <= bound * (1 + 1e-9)
    for row in study["verification"]:  # and through the key itself, every case within half
        assert row["error"] <= 0.5 * row["tolerance"], row


def test_the_resolution_stays_when_the_model_changes_after_load():
    """The tolerance's choice sets the state's size, so changing the model's gravity, a geom's
    contype or the timestep after load must not change it: a new data steps with the same counts
    (a timestep raised past the accuracy's 1024 substeps gets 1024)."""
    model, data, gut = compile_scene('<geom type="plane" size="2 2 .1"/>', length=2.0, young_modulus=1e5,
                                     tolerance=1e-2)
    counts = (gut.control_count, gut.sphere_count)
    model.opt.gravity[:] = 0.0
    model.geom_contype[:] = 0
    model.geom_conaffinity[:] = 0
    model.opt.timestep = 0.05
    fresh = mujoco.MjData(model)
    for _ in range(3):
        mujoco.mj_step(model, fresh)
    again = viscera.intestine(model)
    assert (again.control_count, again.sphere_count) == counts
    assert again.stability()["substeps"] <= 1024
    assert np.isfinite(again.positions(fresh)).all()
