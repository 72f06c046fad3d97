"""Validation cases against analytic references (viscera.validate), with tolerances only:
speed is the benchmarks' business."""

import mujoco
import numpy as np
import pytest

from viscera import validate
from conftest import compile_scene


def test_hanging_rod_stretches_by_mu_g_L2_over_2EA_from_young_modulus():
    """EA = E pi r^2 carried by the stretch springs: the static stretch is exact (linear springs)."""
    row = validate.hanging_rod(20)
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
    row = validate.catenary(50)
    assert row["value"] == pytest.approx(row["reference"], rel=0.005)


def test_cantilever_converges_to_the_beam_deflection_at_first_order():
    """Tip deflection w L^4 / (8 EI) with EI = E pi r^4 / 4: the error halves with the spacing.

    First order, because the clamp pins the first two control points: the point one segment from
    the wall is then held on the axis, a constraint the real cantilever does not have.
    """
    coarse, fine = validate.cantilever(16), validate.cantilever(32)
    errors = [abs(row["value"] - row["reference"]) / row["reference"] for row in (coarse, fine)]
    assert errors[1] < 0.1
    assert 1.6 < errors[0] / errors[1] < 2.4
    assert fine["value"] < fine["reference"]  # over-constrained: stiffer, never softer


def test_rk4_stability_limit_and_how_it_fails():
    """Past its largest stable substep (1.5 ms at the defaults, measured by power iteration in
    issue 3) RK4 blows up, and the divergence guard catches it: restored, counted, never NaN."""
    step, failure = validate.largest_stable_step(dict(length=4, damping=0, self_collision=0, shape="line",
                                                      control_points=250))
    assert 1.2e-3 < step < 2.0e-3
    assert failure == "diverged"
    stiff, _ = validate.largest_stable_step(dict(length=4, damping=0, self_collision=0, shape="line",
                                                 control_points=250, stretch_stiffness=1000))
    assert stiff / step == pytest.approx(np.sqrt(10 / 1000), rel=0.35)  # h_max ~ 1 / sqrt(k)
