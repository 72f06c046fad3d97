"""Validation cases against analytic references (python/tools/validation), with tolerances only:
speed is the benchmarks' business."""

import mujoco
import numpy as np
import pytest

from validation.cantilever.case import cantilever
from validation.catenary.case import catenary
from validation.common import DENSITY, G, MU, RADIUS, SECOND_MOMENT, relax, rk4_substeps
from validation.hanging_rod.case import hanging_rod
from validation.integrators.study import largest_stable_step
from validation.invariants.study import energy_drift, length_preservation
from validation.tip_load.case import tip_load
from validation.vibration.case import vibration
from conftest import compile_scene


def test_hanging_rod_stretches_by_mu_g_L2_over_2EA_from_young_modulus():
    """EA = E pi r^2 carried by the stretch springs: the static stretch is exact (linear springs)."""
    row = hanging_rod(20)
    assert row["value"] == pytest.approx(row["reference"], rel=1e-4)


def test_wall_thickness_sets_the_tube_section():
    """A tube wall of thickness t: EA = E pi (r^2 - (r - t)^2), mass still from the full tube."""
    young, r, t, length = 2.0e5, 0.0125, 0.002, 1.0
    model, data, gut = compile_scene(options='timestep="0.001"', length=length, control_points=20, radius=r,
                                     young_modulus=young, wall_thickness=t, damping=6, self_collision=0,
                                     shape="line", direction=[0, 0, -1], pinned=[0])
    while data.time < 5.0:
        mujoco.mj_step(model, data)
    area = np.pi * (r**2 - (r - t) ** 2)
    expected = gut.mass / length * 9.81 * length**2 / (2.0 * young * area)
    assert gut.length(data) - length == pytest.approx(expected, rel=1e-3)


def test_catenary_sag_within_the_global_length_terms_stretch():
    row = catenary(50)
    assert row["value"] == pytest.approx(row["reference"], rel=0.005)


def test_clamped_cantilever_meets_the_beam_deflection_at_eight_control_points():
    """Tip deflection w L^4 / (8 EI) with EI = E pi r^4 / 4, clamped="start": within 0.1 % from
    8 control points on (the quadratic end closure carries the clamp's moment; the paper's
    linear closure with two pinned points was 33 % too stiff at 8)."""
    for n in (8, 16):
        row = cantilever(n)
        assert row["value"] == pytest.approx(row["reference"], rel=1e-3)


def test_pinning_two_control_points_is_not_a_clamp():
    """The old way to clamp, two pinned control points, holds the curve's point one segment from
    the wall on the axis: much too stiff, which is why `clamped` exists."""
    length, rigidity = 0.5, MU * G * 0.5**3 / 0.08
    config = dict(length=length, control_points=8, radius=RADIUS, density=DENSITY,
                  young_modulus=rigidity / SECOND_MOMENT, stretch_stiffness=2000, damping=30,
                  substeps=rk4_substeps(8, length, rigidity), self_collision=0, shape="line",
                  direction=[1, 0, 0], pinned=[0, 1])
    data, gut, _ = relax(config, 0.6, 0.001)
    assert -gut.axis_points(data, 2)[-1][2] < 0.8 * 0.005


@pytest.mark.parametrize("alpha", [0.03, 1.0, 10.0])
def test_tip_load_follows_the_beam_and_the_elastica(alpha):
    """A dead tip load hung on a grasper: alpha / 3 at small loads, the elastica's large
    deflections (0.30172 L at alpha 1, 0.81061 L at 10) within 0.3 % at 16 control points
    (at alpha 10 the axis stretches P / EA = 0.16 %: the reference is inextensible)."""
    row = tip_load(16, alpha)
    assert row["value"] == pytest.approx(row["reference"], rel=3e-3)


def test_vibration_frequencies_of_the_clamped_beam():
    """The first two bending frequencies, (beta L)^2 sqrt(EI / (mu L^4)) / (2 pi): within 0.1 %
    at 16 control points."""
    for mode in (1, 2):
        row = vibration(16, mode)
        assert row["value"] == pytest.approx(row["reference"], rel=1e-3)


def test_rk4_energy_drift_is_fifth_order_in_the_step():
    """Undamped, RK4 loses (omega h)^6 / 72 of an oscillation's energy per step: over a fixed
    time the drift falls as h^5, and it is small at a tenth of a millisecond."""
    coarse, fine = energy_drift(4e-4, 0.5), energy_drift(2e-4, 0.5)
    order = np.log(coarse["relative_energy_drift"] / fine["relative_energy_drift"]) / np.log(2.0)
    assert 4.0 < order < 6.0
    assert fine["relative_energy_drift"] < 1e-3


def test_global_length_term_keeps_a_hanging_intestine_near_its_length():
    """The default 4 m intestine hanging from one end: the paper's springs alone (EA_eff = 56 N)
    stretch it mu g L^2 / (2 EA_eff) / L = 17 %; the global term (200 N/m) brings it near 1 %."""
    lengths = length_preservation()
    weight_moment = MU * G * 4.0**2 / 2.0  # N m
    assert lengths["without_global_stretch"]["relative_stretch"] == pytest.approx(
        weight_moment / (14.0 * 4.0) / 4.0, rel=0.03)
    assert 0.0 < lengths["with_global_stretch"]["relative_stretch"] < 0.015


def test_rk4_stability_limit_and_how_it_fails():
    """Past its largest stable substep (1.5 ms with the consistent mass matrix, measured by power
    iteration in issue 3) RK4 blows up, and the divergence guard catches it: restored, counted,
    never NaN."""
    step, failure = largest_stable_step(dict(length=4, damping=0, self_collision=0, shape="line",
                                                      control_points=250, mass_matrix="consistent"))
    assert 1.2e-3 < step < 2.0e-3
    assert failure == "diverged"
    stiff, _ = largest_stable_step(dict(length=4, damping=0, self_collision=0, shape="line",
                                                 control_points=250, stretch_stiffness=1000,
                                                 mass_matrix="consistent"))
    assert stiff / step == pytest.approx(np.sqrt(10 / 1000), rel=0.35)  # h_max ~ 1 / sqrt(k)


def test_peers_run_the_same_cases_and_say_what_they_cannot_express():
    """MuJoCo's cable and flexcomp on the same cases, at their own largest stable steps: the
    cable's catenary is an inextensible chain (within 0.5 %), the flexcomp's edge springs carry the
    hanging rod's EA exactly, and the cable, being inextensible, declines the hanging rod."""
    from validation import peers
    cable = peers.run_peer("mujoco_cable", "catenary", 25)
    assert cable["value"] == pytest.approx(cable["reference"], rel=5e-3)
    assert cable["timestep_s"] > 1e-3
    flex = peers.run_peer("mujoco_flexcomp", "hanging_rod", 10)
    assert flex["value"] == pytest.approx(flex["reference"], rel=1e-3)
    assert "inextensible" in peers.run_peer("mujoco_cable", "hanging_rod", 10)["unsupported"]
