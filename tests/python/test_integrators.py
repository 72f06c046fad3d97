"""The integrators through the whole stack: the implicit step where RK4 needs many substeps,
statics independent of the integrator, violent cases caught and recovered, never NaN, and
symplectic Euler's bounded energy."""

import mujoco
import numpy as np
import pytest

from conftest import compile_scene
from validation.cantilever.case import cantilever
from validation.catenary.case import CATENARY_SAG, catenary
from validation.common import quiet_warnings, relax
from validation.integrators.study import energy_bounds, largest_stable_step, stable_outcome

STIFF_ROD = dict(length=4, control_points=250, damping=0, self_collision=0, shape="line", stretch_stiffness=1000,
                 mass_matrix="consistent")  # the paper's band M: the limits quoted are its


def test_implicit_holds_one_2ms_substep_where_rk4_needs_ten():
    """100 times the default stretch stiffness at 250 points: RK4's largest stable substep is
    under 0.2 ms, so a 2 ms MuJoCo step needs at least 10 RK4 substeps; symplectic Euler needs
    more still; the implicit step is stable at one 2 ms substep, and at 20 ms."""
    with quiet_warnings():
        rk4, _ = largest_stable_step(STIFF_ROD, "rk4")
        assert 2e-3 / rk4 >= 10
        symplectic, _ = largest_stable_step(STIFF_ROD, "symplectic_euler")
        assert symplectic < rk4
        assert stable_outcome(STIFF_ROD, 2e-3, integrator="implicit") == "stable"
        assert stable_outcome(STIFF_ROD, 2e-2, integrator="implicit") == "stable"


def test_statics_do_not_depend_on_the_integrator():
    """The stiff catenary (100 times its stretch stiffness) and the clamped cantilever come to the
    same rest under RK4 (at the 16 substeps it needs: 8 diverge) and the implicit step (one 2 ms
    substep): equilibrium is a fixed point of both. Their errors against the references stay RK4's."""
    with quiet_warnings():
        with pytest.raises(RuntimeError):
            catenary(100, "rk4", 0.002, 8, stretch_stiffness=10000.0)
        rk4 = catenary(100, "rk4", 0.002, 16, stretch_stiffness=10000.0)
        implicit = catenary(100, "implicit", 0.002, 1, stretch_stiffness=10000.0)
    assert implicit["value"] == pytest.approx(rk4["value"], rel=1e-5)
    assert implicit["value"] == pytest.approx(implicit["reference"], rel=2e-3)
    rk4 = cantilever(16)
    implicit = cantilever(16, "implicit", 0.002, 1)
    # relaxed 0.6 s at damping 30 /s: what rings is left at e^(-15 x 0.6) = 1.2e-4 of the deflection
    assert implicit["value"] == pytest.approx(rk4["value"], rel=3e-4)
    assert implicit["value"] == pytest.approx(implicit["reference"], rel=1e-3)


def test_lumped_mass_lengthens_the_stable_step_and_keeps_statics():
    """mass_matrix="lumped" (row sums on the diagonal) lifts RK4's largest stable substep on the
    default 4 m, 250-point rod from 1.45 ms to 2.17 ms (the 2 ms step in one substep), and the
    rest shape does not depend on the mass matrix: the catenary's sag stays within RK4's error."""
    base = dict(length=4, damping=0, self_collision=0, shape="line", control_points=250)
    with quiet_warnings():
        consistent, _ = largest_stable_step(dict(base, mass_matrix="consistent"))
        lumped, _ = largest_stable_step(dict(base, mass_matrix="lumped"))
    assert consistent < 2e-3 < lumped
    assert lumped / consistent > 1.4
    depth = np.sqrt(2.0**2 - 1.5**2)  # catenary's V of the rod's length
    sags = []
    for mass_matrix in ("consistent", "lumped"):
        config = dict(length=4, control_points=50, stretch_stiffness=100, bend_stiffness=0, global_stretch_stiffness=5000,
                      damping=4, self_collision=0, shape="polyline", points=[-1.5, 0, 0, 0, 0, -depth, 1.5, 0, 0],
                      pinned=[0, 49], mass_matrix=mass_matrix)
        data, gut, _ = relax(config, 6.0, 0.001)
        sags.append(-gut.axis_points(data, 20001)[:, 2].min())
    assert sags[1] == pytest.approx(sags[0], rel=1e-5)
    assert sags[1] == pytest.approx(CATENARY_SAG, rel=2e-3)


def _finite(model, data, gut):
    return (np.isfinite(gut.positions(data)).all() and np.isfinite(gut.velocities(data)).all()
            and np.isfinite(data.qfrc_passive).all() and np.isfinite(data.qpos).all())


def test_stiff_rk4_steps_are_recovered_by_retries_and_the_implicit_needs_none():
    """At 100 times the default stretch stiffness, RK4 at 2 substeps (given: by default the plugin
    would take the 5 its stability estimate asks for) diverges every step; each is retried with
    more substeps and holds (counted, never NaN). With no retries the steps are restored instead
    (positions kept, velocities zeroed). The implicit step needs neither."""
    config = dict(length=1.0, control_points=40, stretch_stiffness=1000, shape="line", start=[0, 0, 0.3],
                  direction=[1, 0, 0.1], substeps=2)
    body = '<geom type="plane" size="3 3 0.1"/>'
    with quiet_warnings():
        model, data, gut = compile_scene(body, **config)
        for _ in range(100):
            mujoco.mj_step(model, data)
            assert _finite(model, data, gut)
        assert gut.recovery_count(data) > 0 and gut.divergence_count(data) == 0
        model, data, gut = compile_scene(body, divergence_retries=0, **config)
        for _ in range(100):  # the unstable modes grow from rounding within a few steps
            before = gut.positions(data).copy()
            mujoco.mj_step(model, data)
            assert _finite(model, data, gut)
            if gut.divergence_count(data):
                break
        assert gut.divergence_count(data) == 1 and gut.recovery_count(data) == 0
        np.testing.assert_array_equal(gut.positions(data), before)
        assert not gut.velocities(data).any()
        model, data, gut = compile_scene(body, **dict(config, integrator="implicit", substeps=1))
        for _ in range(100):
            mujoco.mj_step(model, data)
        assert _finite(model, data, gut)
        assert gut.recovery_count(data) == 0 and gut.divergence_count(data) == 0


YANK_TOOL = ('<geom type="plane" size="3 3 0.1"/>'
             '<body name="tool" pos="0.5 0 0.0125"><joint name="lift" type="slide" axis="0 0 1"/>'
             '<geom type="sphere" size="0.004" mass="0.05" contype="0" conaffinity="0"/><site name="tip"/>'
             '<body name="jaw"><joint name="jaw" type="hinge" axis="1 0 0"/>'
             '<geom type="sphere" size="0.002" mass="0.001" contype="0" conaffinity="0"/></body></body>')


@pytest.mark.parametrize("integrator,substeps", [("rk4", 2), ("symplectic_euler", 4), ("leapfrog", 4), ("implicit", 1)])
def test_a_yank_at_2_m_per_s_stays_finite(integrator, substeps):
    """A grasper closes on the middle of a resting intestine and yanks it up at 2 m/s for 0.25 s
    on a 20 kN/m hold: every integrator runs stable or is caught and recovered, never NaN, and
    the held point follows the jaw."""
    with quiet_warnings():
        model, data, gut = compile_scene(
            YANK_TOOL, length=1.0, control_points=40, shape="line", start=[0, 0, 0.0125], direction=[1, 0, 0],
            integrator=integrator, substeps=substeps, grasp_sites="tip", grasp_joints="jaw",
            grasp_stiffness=2e4, grasp_slip_force=1e9)
        lift, speed = model.joint("lift").qposadr[0], model.joint("lift").dofadr[0]
        for step in range(150):  # the tool is driven: held for 50 ms (jaw closed), then yanked
            data.qpos[lift] = max(0.0, 2.0 * (step - 25) * model.opt.timestep)
            data.qvel[speed] = 2.0 if step >= 25 else 0.0
            mujoco.mj_step(model, data)
            assert _finite(model, data, gut)
            if step == 24:
                assert gut.grasps(data)[0].status == "holding"
    held = gut.axis_points(data, 3)[1]
    assert held[2] == pytest.approx(data.site("tip").xpos[2], abs=0.02)
    assert gut.divergence_count(data) == 0


def test_symplectic_euler_energy_stays_bounded_for_100_s():
    """A pinned 1 m rod swinging from 20 degrees, undamped, 100 s at 2 ms: symplectic Euler's
    energy error does not grow (the second 50 s stray no further than the first, with margin)
    and stays a few percent of the swing's energy."""
    row = energy_bounds(100.0, ("symplectic_euler",))["symplectic_euler"]
    assert row["second_half"] < 1.5 * row["first_half"]
    assert row["second_half"] < 0.05
