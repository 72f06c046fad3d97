"""Peer rod simulators on the validation cases, so validate.py can chart them beside ours.

    from validation import peers
    peers.run_peer("mujoco_cable", "cantilever", 16)

Peers (all one thread, each run at 0.8x its own largest stable step, found by a
log bisection between 1e-5 s and 2e-2 s on a 0.2 s run of the same case):

- ``mujoco_cable``: MuJoCo's ``mujoco.elasticity.cable`` plugin on a composite
  cable: one rigid cylinder body per segment (mass mu h each), ball joints
  between them, so it is inextensible by construction. The plugin's ``bend``
  is Young's modulus E (Pa) and ``twist`` the shear modulus E / 3 (Pa,
  Poisson 0.5); it takes I and J from the cylinder geom of radius r. A clamp is
  the composite's ``initial="none"`` (the first segment is welded to the world);
  a pin is ``initial="ball"`` plus, for a second pinned end, an equality
  ``connect`` of the last segment's end to the world. Dynamic relaxation by
  damping on the ball joints (N m s/rad), implicit under ``implicitfast``.
- ``mujoco_flexcomp``: a 1D ``flexcomp`` (``type="direct"``): point masses on
  slide joints, edges held at length by soft equality constraints (``<edge
  equality="true"/>``, made as stiff as MuJoCo permits: solref timeconst
  clamped to 2 steps, solimp 0.95-0.99). MuJoCo 3.17 does give 1D flexes bending:
  ``<elasticity young=E/>`` fills ``flex_bending`` with one coefficient per
  interior vertex, E I / (2 h) with I = pi r^4 / 4 from the flex radius, an
  explicit (not implicit) force, which is what caps the step on stiff beams.
  The flexcomp's ``mass`` is split equally over vertices; we reset the vertex
  bodies to lumped masses (mu h inside, mu h / 2 at the ends) so the weight
  is distributed like the other peers'. The compiler refuses a radius above
  half the vertex spacing, so the beams use a thin flex radius (1 mm) and a
  Young's modulus scaled to keep E I. A clamp pins the first two vertices, a
  pin the first one. Damping: dof damping c = gamma m_vertex (N s/m, mass
  proportional), implicit under ``implicitfast``. The hanging rod, which
  needs stretch, swaps the equality for edge springs (``<edge stiffness>``,
  N/m per edge, set to E A / h).
- ``pyelastica``: PyElastica 1.0 ``CosseratRod`` (extensible, shearable,
  E A and alpha_c G A from E, G = E / 3), PositionVerlet stepped with
  ``stepper.step``; the stepping loop is timed after the Numba JIT has run
  (the stability search and a few untimed steps warm it). Clamp:
  ``OneEndFixedBC``; pin: ``GeneralConstraint`` on positions only. Damping:
  ``AnalyticalLinearDamper`` with a uniform rate gamma (1/s).

Cases (r = 0.0125 m, 1000 kg/m^3, mu = 0.490874 kg/m, I = pi r^4 / 4, g = 9.81 m/s^2):

- ``catenary``: 4 m, ends pinned at (+-1.5, 0, 0) m, gravity -z, started from
  an arc of the circle that holds the ends with N equal chords of 4 / N m (so
  every peer starts at its rest length) and relaxed 10 s. Bending: none on the
  MuJoCo peers (no ``elasticity``; ``bend=0``); PyElastica needs E A for
  inextensibility (E = 2e7 Pa, strain ~ 0.1 %) and we lower its bend and twist
  matrices to E = 1e5 Pa (E I = 1.9e-3 N m^2). Value: sag -min z (m);
  reference 1.177335 m.
- ``hanging_rod``: 1 m, E = 1e5 Pa, top pinned at the origin, hanging along
  -z, relaxed 4 s. Value: current length - 1 (m); reference
  mu g L^2 / (2 E A) = 0.049050 m. The cable is inextensible: unsupported.
- ``cantilever``: 0.5 m clamped at the origin along +x, gravity -z,
  E I = mu g L^3 / 0.08 N m^2, relaxed 1 s. Value: tip deflection -z_tip (m);
  reference w L^4 / (8 E I) = 0.005 m.
- ``tip_load``, ``elastica_alpha_{1,2,5,10}``: 0.5 m clamped along +x,
  E I = 1 N m^2, no gravity, dead load P = alpha E I / L^2 (N) along -z on the
  tip (alpha 0.03, 1, 2, 5, 10), relaxed 1.5 s. Value: -z_tip / L; references
  alpha / 3 = 0.01 and the inextensible elastica 0.30172, 0.49346, 0.71379,
  0.81061.
- ``vibration_mode_1``, ``vibration_mode_2``: that beam, weightless and
  undamped, kicked at 1e-3 m/s along +z on its outer quarter (the cable, whose
  segments cannot translate apart, gets the outer quarter turned about the
  joint at 0.75 L, 1e-3 m/s at the tip), tip z sampled every 1 ms for 30
  periods of mode 1 (the step is rounded down to divide 1 ms); frequencies
  (Hz) from a Hann-windowed, zero-padded FFT refined by golden section on the
  exact transform. References 3.19480 and 20.0216 Hz. One run per
  (peer, segments) serves both modes.

run_peer returns {"value", "reference", "wall_s_per_sim_s", "timestep_s",
"segments"}, or {"unsupported": reason}.
"""

from __future__ import annotations

import argparse
import functools
import importlib.util
import pathlib
import sys
import time
from dataclasses import dataclass
from typing import Callable

if __package__ in (None, ""):  # run as a script: python/tools, not this folder, is the import root
    sys.path[0] = str(pathlib.Path(__file__).resolve().parents[1])

import mujoco
import numpy as np

from validation.common import (AREA, BETA_L, DENSITY, G, MU, RADIUS, SECOND_MOMENT,
                                peak_frequency)
from validation.catenary.case import CATENARY_SAG
from validation.tip_load.case import ELASTICA

PEERS: tuple[str, ...] = ("mujoco_flexcomp", "mujoco_cable", "pyelastica")

# equality constraints as stiff as MuJoCo permits: a timeconst under 2 steps is raised to 2 steps
# (refsafe), and an impedance near 1 leaves little of the violation to the soft part
STIFF_EQUALITY = 'solref="1e-4 1" solimp="0.95 0.99 0.001"'
FLEX_BEAM_RADIUS = 0.001  # m: a flexcomp's radius must stay under half its vertex spacing
MIN_STEP, MAX_STEP = 1e-5, 2e-2  # s: the bisection's bracket
STABILITY_SECONDS = 0.2  # s of the case per stability probe
SPEED_LIMIT = 100.0  # m/s: faster than this counts as blown up
SAMPLE = 1e-3  # s: tip sampling of the vibration runs

_BEAMS = (8, 16, 32)
RESOLUTIONS: dict[str, tuple[int, ...]] = {
    "catenary": (25, 50, 100),
    "hanging_rod": (10, 20, 40),
    "cantilever": _BEAMS,
    "tip_load": _BEAMS,
    "elastica_alpha_1": _BEAMS,
    "elastica_alpha_2": _BEAMS,
    "elastica_alpha_5": _BEAMS,
    "elastica_alpha_10": _BEAMS,
    "vibration_mode_1": _BEAMS,
    "vibration_mode_2": _BEAMS,
}


@dataclass(frozen=True)
class Case:
    """One validation setup, peer-independent. Lengths m, moduli Pa, forces N, times s."""
    length_m: float
    young_pa: float  # sets E I (and E A for the extensible peers)
    points: Callable[[int], np.ndarray]  # segments -> (segments + 1, 3) start nodes, m
    ends: str  # "clamp", "pin" (first node) or "pin_pin" (both)
    gravity_m_s2: float  # along -z
    tip_load_n: float  # dead load along -z on the last node
    relax_s: float  # simulated duration
    damping_per_s: float  # mass-proportional rate gamma, 1/s (0: undamped)
    reference: float
    kind: str  # "static" or "vibration"
    excursion_m: float  # no node moves this far from its start in a stable run (a few times the real motion)


def _catenary_points(segments: int, length: float = 4.0, span: float = 3.0) -> np.ndarray:
    """Nodes of N equal chords (length / N m) on the circle arc through (+-span/2, 0, 0), sagging in -z."""
    chord = length / segments
    # the span of N chords turning by phi each, decreasing in phi from length at 0
    lo, hi = 1e-12, 2.0 * np.pi / segments
    for _ in range(200):
        phi = 0.5 * (lo + hi)
        if chord * np.sin(segments * phi / 2.0) / np.sin(phi / 2.0) > span:
            lo = phi
        else:
            hi = phi
    radius = chord / (2.0 * np.sin(phi / 2.0))
    theta = (np.arange(segments + 1) - segments / 2.0) * phi  # from straight down
    centre = radius * np.cos(segments * phi / 2.0)
    return np.stack([radius * np.sin(theta), np.zeros_like(theta), centre - radius * np.cos(theta)], axis=1)


def _line(direction: tuple[float, float, float], length: float) -> Callable[[int], np.ndarray]:
    return lambda n: np.outer(np.linspace(0.0, length, n + 1), direction)


BEAM_LENGTH = 0.5  # m
CANTILEVER_EI = MU * G * BEAM_LENGTH**3 / 0.08  # N m^2: 1 % tip deflection
FIRST_MODE_HZ = BETA_L[0] ** 2 * np.sqrt(1.0 / (MU * BEAM_LENGTH**4)) / (2.0 * np.pi)


def _tip(alpha: float) -> Case:
    return Case(BEAM_LENGTH, 1.0 / SECOND_MOMENT, _line((1, 0, 0), BEAM_LENGTH), "clamp", 0.0,
                alpha / BEAM_LENGTH**2, 1.5, 40.0, alpha / 3.0 if alpha < 0.1 else ELASTICA[alpha], "static",
                max(3.0 * alpha / 3.0, 0.01) if alpha < 0.1 else 2.0 * BEAM_LENGTH)


CASES: dict[str, Case] = {
    "catenary": Case(4.0, 1e5, _catenary_points, "pin_pin", G, 0.0, 10.0, 3.0, CATENARY_SAG, "static", 1.5),
    "hanging_rod": Case(1.0, 1e5, _line((0, 0, -1), 1.0), "pin", G, 0.0, 4.0, 15.0,
                        MU * G / (2.0 * 1e5 * AREA), "static", 0.25),
    "cantilever": Case(BEAM_LENGTH, CANTILEVER_EI / SECOND_MOMENT, _line((1, 0, 0), BEAM_LENGTH), "clamp", G, 0.0,
                       1.0, 100.0, MU * G * BEAM_LENGTH**4 / (8.0 * CANTILEVER_EI), "static", 0.02),
    "tip_load": _tip(0.03),
    "elastica_alpha_1": _tip(1.0),
    "elastica_alpha_2": _tip(2.0),
    "elastica_alpha_5": _tip(5.0),
    "elastica_alpha_10": _tip(10.0),
    "vibration_mode_1": Case(BEAM_LENGTH, 1.0 / SECOND_MOMENT, _line((1, 0, 0), BEAM_LENGTH), "clamp", 0.0, 0.0,
                             30.0 / FIRST_MODE_HZ, 0.0, FIRST_MODE_HZ, "vibration", 0.01),
    "vibration_mode_2": Case(BEAM_LENGTH, 1.0 / SECOND_MOMENT, _line((1, 0, 0), BEAM_LENGTH), "clamp", 0.0, 0.0,
                             30.0 / FIRST_MODE_HZ, 0.0, (BETA_L[1] / BETA_L[0]) ** 2 * FIRST_MODE_HZ, "vibration", 0.01),
}
PYELASTICA_CATENARY_YOUNG = 2e7  # Pa: E A for ~0.1 % strain; bending stays at the case's 1e5 Pa


class Unsupported(Exception):
    """The peer cannot express the case; the message is the one-line reason."""


class _Rod:
    """What the case drivers need from a peer: step, the centreline nodes, the clock."""
    timestep: float  # s

    def step(self) -> None: ...

    def nodes(self) -> np.ndarray:  # (segments + 1, 3), m
        ...

    def failed(self) -> bool:  # the peer itself reported an instability
        return False


class _MujocoRod(_Rod):
    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, nodes: Callable[[], np.ndarray]):
        self.model, self.data, self._nodes, self.timestep = model, data, nodes, model.opt.timestep

    def step(self) -> None:
        mujoco.mj_step(self.model, self.data)

    def nodes(self) -> np.ndarray:
        return self._nodes()

    def failed(self) -> bool:
        # MuJoCo resets the state on a bad acceleration, which would hide a blow-up
        return bool(self.data.warning[mujoco.mjtWarning.mjWARN_BADQACC].number)


def _mjcf(body: str, timestep: float, gravity: float, extension: str = "", extra: str = "") -> str:
    return (f'<mujoco><option timestep="{timestep}" integrator="implicitfast" gravity="0 0 {-gravity}"/>'
            f'{extension}<worldbody><site name="origin"/>{body}</worldbody>{extra}</mujoco>')


def _build_flexcomp(case: Case, segments: int, timestep: float) -> _Rod:
    points = case.points(segments)
    h = case.length_m / segments  # m
    pins = {"clamp": "0 1", "pin": "0", "pin_pin": f"0 {segments}"}[case.ends]
    if case is CASES["hanging_rod"]:
        edge = f'<edge stiffness="{case.young_pa * AREA / h:.9g}" damping="0"/>'  # N/m per edge: E A / h
        radius, elasticity = RADIUS, ""
    else:
        edge = f'<edge equality="true" {STIFF_EQUALITY}/>'
        radius = RADIUS if case.ends == "pin_pin" else FLEX_BEAM_RADIUS
        # keep E I of the solid 12.5 mm section on the thin flex
        elasticity = "" if case.ends == "pin_pin" else \
            f'<elasticity young="{case.young_pa * SECOND_MOMENT / (np.pi * radius**4 / 4.0):.9g}"/>'
    body = (f'<flexcomp name="rod" type="direct" dim="1" radius="{radius}" mass="{MU * case.length_m:.9g}" '
            f'point="{" ".join(f"{v:.12g}" for v in points.ravel())}" '
            f'element="{" ".join(f"{i} {i + 1}" for i in range(segments))}">{edge}{elasticity}'
            f'<pin id="{pins}"/><contact selfcollide="none" contype="0" conaffinity="0"/></flexcomp>')
    model = mujoco.MjModel.from_xml_string(_mjcf(body, timestep, case.gravity_m_s2))
    lumped = np.full(segments + 1, MU * h)
    lumped[[0, -1]] /= 2.0
    for vertex, b in enumerate(model.flex_vertbodyid):
        if b > 0:  # pinned vertices are the world
            model.body_mass[b] = lumped[vertex]
            dofs = slice(model.body_dofadr[b], model.body_dofadr[b] + model.body_dofnum[b])
            model.dof_damping[dofs] = case.damping_per_s * lumped[vertex]  # N s/m
    data = mujoco.MjData(model)
    mujoco.mj_setConst(model, data)  # masses changed after compiling
    tip_body = model.flex_vertbodyid[-1]
    data.xfrc_applied[tip_body, 2] = -case.tip_load_n  # at the vertex: a point mass's centre
    if case.kind == "vibration":
        for vertex, b in enumerate(model.flex_vertbodyid):
            if b > 0 and vertex >= 0.75 * segments:
                data.qvel[model.body_dofadr[b] + 2] = 1e-3  # m/s; the third slide joint is z
    mujoco.mj_forward(model, data)  # positions are zeros until the first forward pass
    return _MujocoRod(model, data, lambda: data.flexvert_xpos.copy())


def _build_cable(case: Case, segments: int, timestep: float) -> _Rod:
    if case is CASES["hanging_rod"]:
        raise Unsupported("the composite cable is rigid segments on ball joints: inextensible, no stretch to measure")
    points = case.points(segments)
    h = case.length_m / segments
    bend = 0.0 if case.ends == "pin_pin" else case.young_pa  # the catenary wants no bending at all
    initial = "none" if case.ends == "clamp" else "ball"
    body = (f'<composite prefix="c" type="cable" initial="{initial}" '
            f'vertex="{" ".join(f"{v:.12g}" for v in points.ravel())}">'
            '<plugin plugin="mujoco.elasticity.cable">'
            f'<config key="twist" value="{bend / 3.0:.9g}"/><config key="bend" value="{bend:.9g}"/>'
            '<config key="vmax" value="0"/></plugin>'
            f'<geom type="cylinder" size="{RADIUS}" mass="{MU * h:.9g}" contype="0" conaffinity="0"/></composite>')
    extra = ""
    if case.ends == "pin_pin":
        extra += f'<equality><connect body1="cB_last" anchor="{h:.12g} 0 0" {STIFF_EQUALITY}/></equality>'
    if case.tip_load_n:
        # a dead load at the tip: a site actuator whose gear is in the world-fixed frame of "origin"
        extra += '<actuator><general name="load" site="cS_last" refsite="origin" gear="0 0 1 0 0 0"/></actuator>'
    model = mujoco.MjModel.from_xml_string(
        _mjcf(body, timestep, case.gravity_m_s2, '<extension><plugin plugin="mujoco.elasticity.cable"/></extension>',
              extra))
    names = ["cB_first"] + [f"cB_{i}" for i in range(1, segments - 1)] + ["cB_last"]
    bodies = np.array([model.body(n).id for n in names])
    tip_site = model.site("cS_last").id
    # relax through the joints: stiffness-proportional for the beams (beta = 2 zeta / omega_1 on the
    # joint's E I / h), a fixed small value scaled like the chain's pendulum for the catenary
    if case.damping_per_s:
        rigidity = case.young_pa * SECOND_MOMENT
        if case.ends == "pin_pin":
            joint = case.damping_per_s * MU * h * (case.length_m / 4.0) ** 2
        else:
            omega = BETA_L[0] ** 2 * np.sqrt(rigidity / (MU * case.length_m**4))
            joint = (case.damping_per_s / omega**2) * rigidity / h  # N m s/rad, zeta ~ gamma / (2 omega)
        model.dof_damping[:] = joint
    data = mujoco.MjData(model)
    if case.tip_load_n:
        data.ctrl[0] = -case.tip_load_n
    if case.kind == "vibration":
        # turn the outer quarter about its first joint: 1e-3 m/s at the tip, along +z
        k = int(np.ceil(0.75 * segments))
        mujoco.mj_forward(model, data)
        lever = case.length_m - k * h
        omega_world = np.array([0.0, -1e-3 / lever, 0.0])
        joint = model.body_jntadr[bodies[k]]
        local = data.xmat[bodies[k]].reshape(3, 3).T @ omega_world  # ball joint velocity is in the child frame
        data.qvel[model.jnt_dofadr[joint]:model.jnt_dofadr[joint] + 3] = local

    def nodes() -> np.ndarray:
        return np.vstack([data.xpos[bodies], data.site_xpos[tip_site]])

    mujoco.mj_forward(model, data)  # positions are zeros until the first forward pass
    return _MujocoRod(model, data, nodes)


class _ElasticaRod(_Rod):
    def __init__(self, simulator, stepper, rod, timestep: float):
        self.simulator, self.stepper, self.rod, self.timestep = simulator, stepper, rod, timestep
        self.time = 0.0

    def step(self) -> None:
        self.time = self.stepper.step(self.simulator, self.time, self.timestep)

    def nodes(self) -> np.ndarray:
        return self.rod.position_collection.T.copy()


def _build_elastica(case: Case, segments: int, timestep: float) -> _Rod:
    import elastica as ea  # optional extra: only when this peer runs

    class Simulator(ea.BaseSystemCollection, ea.Constraints, ea.Forcing, ea.Damping):
        pass

    points = case.points(segments)
    tangents = np.diff(points, axis=0)
    tangents /= np.linalg.norm(tangents, axis=1)[:, None]
    normal = np.array([0.0, 1.0, 0.0]) if abs(tangents[0, 1]) < 0.9 else np.array([1.0, 0.0, 0.0])
    if case.ends == "pin_pin":
        normal = np.array([0.0, 1.0, 0.0])  # the arc lies in x-z
    directors = np.empty((3, 3, segments))
    directors[0] = normal[:, None]
    directors[1] = np.cross(tangents, normal).T  # d2 = d3 x d1 keeps (d1, d2, d3) right-handed
    directors[2] = tangents.T
    young = PYELASTICA_CATENARY_YOUNG if case.ends == "pin_pin" else case.young_pa
    rod = ea.CosseratRod.straight_rod(
        segments, points[0], tangents[0], normal, case.length_m, RADIUS, DENSITY, youngs_modulus=young,
        shear_modulus=young / 3.0, position=points.T.copy(), directors=directors)
    if young != case.young_pa:
        rod.bend_matrix *= case.young_pa / young  # stiff in stretch, soft in bending and twist
    simulator = Simulator()
    simulator.append(rod)
    if case.ends == "clamp":
        simulator.constrain(rod).using(ea.OneEndFixedBC, constrained_position_idx=(0,), constrained_director_idx=(0,))
    else:
        pinned = (0, -1) if case.ends == "pin_pin" else (0,)
        simulator.constrain(rod).using(
            ea.GeneralConstraint, constrained_position_idx=pinned, constrained_director_idx=pinned,
            translational_constraint_selector=np.array([True, True, True]),
            rotational_constraint_selector=np.array([False, False, False]))
    if case.gravity_m_s2:
        simulator.add_forcing_to(rod).using(ea.GravityForces, acc_gravity=np.array([0.0, 0.0, -case.gravity_m_s2]))
    if case.tip_load_n:
        simulator.add_forcing_to(rod).using(ea.EndpointForces, start_force=np.zeros(3),
                                            end_force=np.array([0.0, 0.0, -case.tip_load_n]), ramp_up_time=1e-12)
    if case.damping_per_s:
        simulator.dampen(rod).using(ea.AnalyticalLinearDamper, uniform_damping_constant=case.damping_per_s,
                                    time_step=timestep)
    if case.kind == "vibration":
        rod.velocity_collection[2, points[:, 0] >= 0.75 * case.length_m - 1e-12] = 1e-3  # m/s
    simulator.finalize()
    return _ElasticaRod(simulator, ea.PositionVerlet(), rod, timestep)


_BUILDERS: dict[str, Callable[[Case, int, float], _Rod]] = {
    "mujoco_flexcomp": _build_flexcomp, "mujoco_cable": _build_cable, "pyelastica": _build_elastica}


def available(peer: str) -> bool:
    """Whether the peer can run here: the MuJoCo ones always, PyElastica if importable."""
    if peer == "pyelastica":
        return importlib.util.find_spec("elastica") is not None
    return peer in PEERS


def _quiet(function: Callable) -> Callable:
    """Silence MuJoCo's instability warnings while probing steps past the limit."""
    @functools.wraps(function)
    def wrapper(*args, **kwargs):
        mujoco.set_mju_user_warning(lambda message: None)
        try:
            return function(*args, **kwargs)
        finally:
            mujoco.set_mju_user_warning(None)
    return wrapper


@_quiet
def _stable(peer: str, case: Case, segments: int, timestep: float) -> bool:
    """Whether a STABILITY_SECONDS run of the case stays finite, under SPEED_LIMIT m/s, within the
    case's excursion_m of its start, within 5 % of its length (20 % for the hanging rod), and ends without a step-to-step sawtooth (a bounded instability
    that damping or the constraints keep from blowing up still makes garbage)."""
    rod = _BUILDERS[peer](case, segments, timestep)
    start = rod.nodes()
    steps = max(10, int(np.ceil(STABILITY_SECONDS / timestep)))
    history = [start, start, start]
    with np.errstate(all="ignore"):
        for i in range(steps):
            rod.step()
            if i % 5 >= 2 or i >= steps - 3:
                history = history[1:] + [rod.nodes()]
            if i % 5 == 4:  # every 5 steps: node speeds over the last step, m/s
                x = history[-1]
                speed = np.max(np.linalg.norm(x - history[-2], axis=1)) / timestep
                if rod.failed() or not np.isfinite(x).all() or speed > SPEED_LIMIT \
                        or np.max(np.linalg.norm(x - start, axis=1)) > case.excursion_m:
                    return False
        x = history[-1]
        if rod.failed() or not np.isfinite(x).all() or np.max(np.linalg.norm(x - start, axis=1)) > case.excursion_m:
            return False
        # stretch runaway: soft constraints at a long step can hold a bounded but stretched rod
        allowed = 0.2 if case is CASES["hanging_rod"] else 0.05  # the hanging rod really stretches 5 %
        if abs(np.linalg.norm(np.diff(x, axis=0), axis=1).sum() / case.length_m - 1.0) > allowed:
            return False
        first = np.abs(history[2] - history[1]).max()
        second = np.abs(history[2] - 2.0 * history[1] + history[0]).max()
        return not (second > first and first > 1e-9 * case.length_m)


@functools.lru_cache(maxsize=None)
def largest_stable_step(peer: str, case_name: str, segments: int) -> float:
    """Largest stable step (s) by bisection in log between MIN_STEP and MAX_STEP (cached)."""
    case = CASES[case_name]
    if _stable(peer, case, segments, MAX_STEP):
        return MAX_STEP
    low, high = MIN_STEP, MAX_STEP
    for _ in range(9):  # the bracket spans 2000x: 9 halvings of its log leave ~1.5 %
        middle = np.sqrt(low * high)
        if _stable(peer, case, segments, middle):
            low = middle
        else:
            high = middle
    return float(low)


def _static(peer: str, case_name: str, segments: int, timestep: float) -> tuple[float, float]:
    """Relax the case; return (value, wall s per sim s)."""
    case = CASES[case_name]
    rod = _BUILDERS[peer](case, segments, timestep)
    warm = 5  # untimed: JIT and caches
    for _ in range(warm):
        rod.step()
    steps = max(1, int(round(case.relax_s / timestep)) - warm)
    start = time.perf_counter()
    for _ in range(steps):
        rod.step()
    wall = time.perf_counter() - start
    x = rod.nodes()
    if rod.failed() or not np.isfinite(x).all():
        raise FloatingPointError("diverged")
    if case_name == "catenary":
        value = -x[:, 2].min()
    elif case_name == "hanging_rod":
        value = np.linalg.norm(np.diff(x, axis=0), axis=1).sum() - case.length_m
    elif case_name == "cantilever":
        value = -x[-1, 2]
    else:
        value = -x[-1, 2] / case.length_m
    return float(value), float(wall / (steps * timestep))


@functools.lru_cache(maxsize=None)
def _vibration(peer: str, segments: int, timestep: float) -> tuple[float, float, float]:
    """One undamped run for both modes: (f1 Hz, f2 Hz, wall s per sim s)."""
    case = CASES["vibration_mode_1"]
    rod = _BUILDERS[peer](case, segments, timestep)
    per_sample = int(round(SAMPLE / timestep))
    samples = int(round(case.relax_s / SAMPLE))
    tip = np.empty(samples)
    start = time.perf_counter()
    for i in range(samples):
        for _ in range(per_sample):
            rod.step()
        tip[i] = rod.nodes()[-1, 2]
    wall = time.perf_counter() - start
    if rod.failed() or not np.isfinite(tip).all() or np.abs(tip).max() > 0.1 * case.length_m:
        raise FloatingPointError("diverged")
    ratio = (BETA_L[1] / BETA_L[0]) ** 2
    return (float(peak_frequency(tip, SAMPLE, 0.5 * FIRST_MODE_HZ, 1.5 * FIRST_MODE_HZ)),
            float(peak_frequency(tip, SAMPLE, 0.5 * ratio * FIRST_MODE_HZ, 1.5 * ratio * FIRST_MODE_HZ)),
            float(wall / (samples * SAMPLE)))


def _usable_step(peer: str, case_name: str, segments: int) -> float:
    """0.8x the largest stable step (s); vibration runs round it down to divide the 1 ms sampling."""
    step = 0.8 * largest_stable_step(peer, case_name.replace("vibration_mode_2", "vibration_mode_1"), segments)
    if CASES[case_name].kind == "vibration":
        step = SAMPLE / np.ceil(SAMPLE / step) if step < SAMPLE else SAMPLE
    return float(step)


def run_peer(peer: str, case: str, segments: int) -> dict:
    """Run `peer` on `case` with `segments` segments at 0.8x its largest stable step.

    Returns {"value", "reference", "wall_s_per_sim_s", "timestep_s" (s), "segments"} (value in the
    case's unit: m, tip deflection / L, or Hz), or {"unsupported": reason}. If the run diverges at
    that step (a slow instability the short probe missed) the step is halved, up to 3 times."""
    if peer not in PEERS:
        raise ValueError(f"unknown peer {peer!r}; expected one of {PEERS}")
    if case not in CASES:
        raise ValueError(f"unknown case {case!r}; expected one of {tuple(CASES)}")
    if not available(peer):
        return {"unsupported": f'{peer} is not installed (pip install ".[peers]")'}
    try:
        timestep = _usable_step(peer, case, segments)
    except Unsupported as reason:
        return {"unsupported": str(reason)}
    spec = CASES[case]
    for _ in range(4):
        try:
            if spec.kind == "vibration":
                f1, f2, cost = _vibration(peer, segments, timestep)
                value = f1 if case == "vibration_mode_1" else f2
            else:
                value, cost = _quiet(_static)(peer, case, segments, timestep)
            break
        except FloatingPointError:
            timestep /= 2.0
    else:
        return {"unsupported": f"diverged even at {timestep * 2:.3g} s"}
    return {"value": value, "reference": float(spec.reference), "wall_s_per_sim_s": cost, "timestep_s": timestep,
            "segments": segments}


def build_parser() -> argparse.ArgumentParser:
    return argparse.ArgumentParser(
        prog="python python/tools/validation/peers.py",
        description="Run every peer rod simulator (MuJoCo's cable and flexcomp, PyElastica) on every validation "
                    "case at its smallest resolution and print value, reference, error and cost. PyElastica is "
                    'optional: pip install ".[peers]". The full charts: python python/tools/validate.py.')


def main(argv: list[str] | None = None) -> None:
    """Print every (peer, case) at the smallest resolution."""
    build_parser().parse_args(argv)
    print(f"{'peer':16s} {'case':18s} {'n':>4s} {'value':>10s} {'reference':>10s} {'rel.err':>9s} "
          f"{'wall/sim':>9s} {'step s':>9s}")
    for case, resolutions in RESOLUTIONS.items():
        for peer in PEERS:
            result = run_peer(peer, case, resolutions[0])
            if "unsupported" in result:
                print(f"{peer:16s} {case:18s} {resolutions[0]:4d}  unsupported: {result['unsupported']}")
                continue
            error = (result["value"] - result["reference"]) / result["reference"]
            print(f"{peer:16s} {case:18s} {resolutions[0]:4d} {result['value']:10.5g} {result['reference']:10.5g} "
                  f"{error:9.2e} {result['wall_s_per_sim_s']:9.3g} {result['timestep_s']:9.3g}")


if __name__ == "__main__":
    main()
