"""The abdominal cavity scene: its settled intestine, attached ends, and the settling procedure."""

import mujoco
import numpy as np
import pytest

import viscera
import settle
from viscera.tasks import scene

from test_package import ROOT

ABDOMEN = ROOT / "assets" / "scenes" / "abdomen.xml"


@pytest.fixture(scope="module")
def cavity():
    model = mujoco.MjModel.from_xml_path(str(ABDOMEN))
    return model, viscera.intestine(model)


def test_the_settling_path_starts_and_ends_on_the_posterior_wall():
    path = settle.initial_path(3.0, 0.0125)
    assert np.linalg.norm(np.diff(path, axis=0), axis=1).sum() == pytest.approx(3.0, abs=1e-9)
    first, last = path[0], path[-1]
    assert first[2] == pytest.approx(0.0125) and last[2] == pytest.approx(0.0125)  # resting on the wall
    assert first[0] < -0.1 and first[1] > 0.09    # duodenojejunal flexure: left, cranial
    assert last[0] > 0.1 and last[1] < -0.09      # ileocaecal junction: right, caudal
    inner = np.array(settle.HALF_WIDTH)
    assert (np.abs(path[:, :2]) <= inner - 0.0125).all()  # inside the cavity


def test_the_shipped_intestine_is_at_rest_with_its_ends_on_the_wall(cavity):
    """Each episode starts from the settled state: stepping it with the tools still moves no
    control point by more than 2 mm in 1 s, and the pinned ends stay on the posterior wall."""
    model, gut = cavity
    data = mujoco.MjData(model)
    start = gut.positions(data).copy()
    assert start[[0, -1], 2] == pytest.approx([gut.radius, gut.radius], abs=0.003)
    for _ in range(500):
        mujoco.mj_step(model, data)
    moved = np.linalg.norm(gut.positions(data) - start, axis=1)
    assert moved.max() < 0.002
    assert moved[0] == 0.0 and moved[-1] == 0.0  # pinned
    assert gut.divergence_count(data) == 0
    assert gut.config["shape"] == "control_points" and len(gut.config["points"].split()) == 3 * gut.control_count


def test_rewriting_the_shape_keeps_the_rest_of_the_scene():
    text = ABDOMEN.read_text()
    rewritten = settle._with_shape(text, "line", None)
    assert '<config key="shape" value="line"/>' in rewritten
    assert '<config key="points" value=""/>' in rewritten
    assert rewritten.count("<geom") == text.count("<geom")
    with pytest.raises(ValueError, match="exactly one"):
        settle._with_shape("<mujoco/>", "line", None)


SWEEP_CONFIGS = {"defaults": {}, "consistent_mass": {"mass_matrix": "consistent", "sleep": "0"},
                 "rk4": {"integrator": "rk4"},
                 **scene.tissue_corners()}


@pytest.mark.parametrize("name", list(SWEEP_CONFIGS))
def test_the_vigorous_sweep_needs_no_recovery(name):
    """bench_cavity's sweep (every actuator on a sine within its range, 20 s): at the substeps
    chosen from the timestep the intestine never diverges, not even once recovered, at the
    defaults, with the band mass matrix, under RK4, and with the tissue the tasks draw at the ends
    of every range (2 x 2 x 2 corners: mass, springs, grip).
    - At 15 s a tool presses piled loops against the wall: with the contact damping's rate left
      out of the substep count, leapfrog with the band mass matrix took 3 substeps there and blew
      up; it takes 4 now, the lumped default 3.
    - Light, stiff and grippy, a tool pressing piled loops on each other put up to 14 contacts on
      a sphere, whose damping added up past its explicit limit (gamma h < 2): it recovered twice
      in 20 s; the contact pass now limits it there (src/vsc_contact_load.h)."""
    import bench_cavity
    config = {key: str(value) for key, value in SWEEP_CONFIGS[name].items()}
    model = mujoco.MjModel.from_xml_string(scene.with_intestine_config(ABDOMEN.read_text(), config))
    data = mujoco.MjData(model)
    gut = viscera.intestine(model)
    for ctrl in bench_cavity.sweep_controls(model, 20.0):
        data.ctrl[:] = ctrl
        mujoco.mj_step(model, data)
    assert gut.recovery_count(data) == 0 and gut.divergence_count(data) == 0
    assert np.abs(gut.velocities(data)).max() < 2.0  # m/s: tools move the bowel, nothing flings it
