"""The score of an episode: skill and tissue safety, for a person, a script or a learned policy.

    tracer = Tracer(env)                 # after env.reset()
    tracer.sample(env)                   # after the reset and after every env.step
    score(tracer.trace)                  # a JSON-able dict (docs/rehearsal.md defines every entry)
    assess(viscera.recording.load("episode.npz"))   # the same, by replaying a recording

The trace holds, per control tick, what the score needs (SI units): each tool's working point
and shaft direction, the tissue's force on it (its `<tool>_force` sensor), whether it touches a
cavity wall and whether the laparoscope sees it, and for a grasper its hold and pinch. `score`
is a pure function of the trace, so a trace built by hand gives hand-computable values.

Skill follows the trainers surgeons know (LapSim: time, path length and angular path per hand;
the da Vinci skills simulator: economy of motion, instrument collisions, instruments out of
view, excessive force, drops). Safety compares the tissue's loads with published limits, each a
named constant below with its source.

The grasp's pinch is the plugin's (docs/model.md#grasp): the jaws are taken to meet the tissue at
the angle where the plugin counts them closed (`grasp_closed_below`, 0.1 rad by default); the
jaw's position actuator, commanded further closed, squeezes with its spring: torque kp (angle at
meeting - command), pinch = torque / lever (`grasp_lever`: 7.76 mm, the jaw's middle). The hold
slips once it pulls harder than the jaws' friction gives at that pinch. With the abdomen's
grasper (kp 0.5 N m/rad) a fully closed command pinches 6.4 N: about what novices use, more than
prevents slip, below perforation.
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np

from viscera import laparoscope

# -- tissue limits, each with its source
PERFORATION_PINCH_N = 10.3
"""Grasping pinch at which human small bowel perforates: 10.3 +- 2.9 N (Heijnsdijk, de Visser,
Dankelman, Gouma: Slip and damage properties of jejunum and colon, Surg Endosc 17:1427-1430, 2003)."""
SLIP_PREVENTING_PINCH_N = 3.0
"""Pinch that prevents the bowel slipping out of the jaws, against the 6.8 N that novices use
(de Visser, Heijnsdijk, Herder, Pistecky: Forces and displacements in colon surgery, Surg Endosc
16:1426-1430, 2002; Heijnsdijk et al. 2004): grip beyond it is force the tissue bears for nothing."""
NOVICE_PINCH_N = 6.8
"""What novices pinch where 3 N would hold (de Visser et al. above)."""
FORCE_TIME_PRODUCT_LIMIT_NS = 300.0
"""Force-time product (the area under one grasp's force against time) above which grasped colon
shows histological damage (Barrie, Russell, Hood, Jayne, Neville, Culmer: An in vivo analysis of
safe laparoscopic grasping thresholds for colorectal surgery, Surg Endosc 32:4244-4250, 2018)."""
TRACTION_LIMIT_N = 4.62
"""Tool force on the tissue counted as excessive: the mean force at which a suture tears through
human small bowel, 4.62 +- 1.40 N (Gong et al., Characterizing the suture pullout force for
human small bowel, J Biomech Eng 146(1), 2023). A proxy: no limit for a blunt tool pushing or
pulling the bowel was found; this is the smallest published load at which the human small
bowel's wall fails under a concentrated pull."""

# -- the figures a score is read by against the reference band (python/tools/reference_band.py):
# (name, how to read it from a score, unit); less is better for every one
BAND_FIGURES = (
    ("time_s", lambda s: s["time_s"], "s"),
    ("path_length_m", lambda s: sum(t["path_length_m"] for t in s["tools"].values()), "m"),
    ("angular_path_deg", lambda s: sum(t["angular_path_deg"] for t in s["tools"].values()), "deg"),
    ("idle_s", lambda s: sum(t["idle_s"] for t in s["tools"].values()), "s"),
    ("peak_force_n", lambda s: max(t["peak_force_n"] for t in s["tools"].values()), "N"),
    ("out_of_view_s", lambda s: sum(t["out_of_view_s"] for t in s["tools"].values()), "s"),
    ("peak_pinch_n", lambda s: s["tissue"]["peak_pinch_n"], "N"),
    ("force_time_product_ns", lambda s: s["tissue"]["force_time_product_ns"], "N s"),
    ("safety_cost", lambda s: s["safety_cost"], ""),
)

# -- the camera's figures: a laparoscope that a trainee steers (viscera.laparoscope) is scored as
# camera navigation is trained (a target kept centred in the image: Korndorffer, Hayes, Dunne et
# al., Development and transferability of a cost-effective laparoscopic camera navigation
# simulator, Surg Endosc 19:161-167, 2005; LapSim's camera navigation task): the time each tool
# is centred, the time the horizon is off level and the camera's travel. The thresholds are
# definitions (viscera.laparoscope.CENTRE_FRACTION, HORIZON_TOLERANCE_DEG), not literature.
HORIZON_TOLERANCE_DEG = 15.0  # the image's up this far or more from the cranial direction: the horizon is off

# -- skill thresholds (definitions, not literature)
IDLE_SPEED_M_S = 0.005      # a tool whose working point moves slower than this is idle
WALL_CONTACT_M = 0.001      # a tool closer than this to a cavity wall touches it
DROP_HEIGHT_M = 0.03        # a hold released this far above the posterior wall is dropped, not laid down
INSIDE_DEPTH_M = 0.02       # a tool counts as out of view only once inserted this far (a parked tool is not)
WALLS = ("posterior_wall", "left_flank", "right_flank", "pelvis_floor", "cranial_wall")  # the shaft crosses the anterior wall


@dataclasses.dataclass
class Trace:
    """Per control tick (first row: after the reset), per tool where it says (tools, ...)."""

    tools: tuple[str, ...]
    graspers: tuple[str, ...]                                 # tools with jaws, in `tools`
    time: list = dataclasses.field(default_factory=list)      # s
    tip: list = dataclasses.field(default_factory=list)       # (tools, 3) m, working points
    shaft: list = dataclasses.field(default_factory=list)     # (tools, 3) unit, trocar to tip
    force: list = dataclasses.field(default_factory=list)     # (tools, 3) N, the tissue's force on each tool
    wall: list = dataclasses.field(default_factory=list)      # (tools,) bool, touching a cavity wall
    in_view: list = dataclasses.field(default_factory=list)   # (tools,) bool, the laparoscope sees it (Physics.tool_seen)
    inside: list = dataclasses.field(default_factory=list)    # (tools,) bool, inserted past INSIDE_DEPTH_M
    holding: list = dataclasses.field(default_factory=list)   # (tools,) bool, its jaws hold the bowel
    jaw_closed: list = dataclasses.field(default_factory=list)  # (tools,) bool, the jaw at or below its closing angle
    pinch: list = dataclasses.field(default_factory=list)     # (tools,) N, the jaws' squeeze while holding
    held_height: list = dataclasses.field(default_factory=list)  # (tools,) m above the posterior wall, nan if not holding
    centred: list = dataclasses.field(default_factory=list)   # (tools,) bool, in the middle of the laparoscope's image
    camera_position: list = dataclasses.field(default_factory=list)  # (3,) m, the laparoscope's
    camera_view: list = dataclasses.field(default_factory=list)      # (3,) unit, where it looks
    horizon_deg: list = dataclasses.field(default_factory=list)      # the image's up from the cranial direction
    damage_max: list = dataclasses.field(default_factory=list)       # the bowel wall's worst bruise, 0 to 1
    damage_where_m: list = dataclasses.field(default_factory=list)   # m along the bowel from its start, of the worst
    perforations_where_m: list = dataclasses.field(default_factory=list)  # per tick, a list: m, each torn stretch's middle
    success: bool = False

    def arrays(self) -> dict[str, np.ndarray]:
        return {name: np.asarray(getattr(self, name), dtype=float) for name in
                ("time", "tip", "shaft", "force", "wall", "in_view", "inside", "holding", "jaw_closed", "pinch",
                 "held_height", "centred", "camera_position", "camera_view", "horizon_deg")}


class Tracer:
    """Samples an environment's tools into a Trace (see the module doc)."""

    def __init__(self, env):
        physics = env.physics
        model = physics.model.ptr
        self.tools = tuple(physics.tools())
        graspers = set(physics.graspers())
        self.trace = Trace(self.tools, tuple(t for t in self.tools if t in graspers))
        self._model = model
        self._walls = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, w) for w in WALLS]
        self._walls = [w for w in self._walls if w >= 0]
        self._floor = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "posterior_wall")
        self._geoms = {t: [g for g in range(model.ngeom) if _body_of_tool(model, int(model.geom_bodyid[g]), t)]
                       for t in self.tools}
        self._camera = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, "laparoscope")
        self._depth = {t: model.jnt_qposadr[model.joint(f"{t}_depth").id] for t in self.tools}
        gut = physics.intestine()
        self._closed = closing_angle(gut)
        self._jaw = {g: model.jnt_qposadr[model.joint(f"{g}_jaw").id] for g in self.trace.graspers}
        self._sites = {grasp.site.removesuffix("_tip"): i for i, grasp in enumerate(gut.grasps(physics.data.ptr))}

    def sample(self, env) -> dict[str, float]:
        """Append the tools now to the trace; returns each grasper's pinch (N, `pinches`)."""
        physics = env.physics
        model, data = physics.model.ptr, physics.data.ptr
        trace = self.trace
        trace.time.append(float(data.time))
        grasps = physics.intestine().grasps(data)
        pinch_now = pinches(physics)
        floor = float(data.geom_xpos[self._floor][2] + model.geom_size[self._floor][2]) if self._floor >= 0 else 0.0
        tips, shafts, forces, walls, seen, inside, holding, closed, pinch, height, centred = ([] for _ in range(11))
        axis, radius = physics.dense_axis(), physics.intestine().radius  # what may hide a tool
        for tool in self.tools:
            tip = physics.working_point(tool)
            trocar = physics.named.data.xpos[f"{tool}_trocar"]
            direction = tip - trocar
            tips.append(tip)
            shafts.append(direction / max(np.linalg.norm(direction), 1e-12))
            forces.append(np.array(physics.named.data.sensordata[f"{tool}_force"][:3], dtype=float))
            walls.append(self._touches_wall(model, data, tool))
            seen.append(physics.tool_seen(tool, axis, radius) if self._camera >= 0 else True)
            where = laparoscope.image_point(model, data, self._camera, tip) if self._camera >= 0 else None
            centred.append(where is not None and max(abs(where[0]), abs(where[1])) <= laparoscope.CENTRE_FRACTION)
            inside.append(float(data.qpos[self._depth[tool]]) > INSIDE_DEPTH_M)
            grasp = grasps[self._sites[tool]] if tool in self._sites else None
            held = bool(grasp is not None and grasp.holding)
            holding.append(held)
            closed.append(tool in self._jaw and float(data.qpos[self._jaw[tool]]) <= self._closed)
            pinch.append(pinch_now.get(tool, 0.0))
            height.append(float(physics.axis_point_at(grasp.abscissa)[2]) - floor if held else np.nan)
        trace.tip.append(tips)
        trace.shaft.append(shafts)
        trace.force.append(forces)
        trace.wall.append(walls)
        trace.in_view.append(seen)
        trace.inside.append(inside)
        trace.holding.append(holding)
        trace.jaw_closed.append(closed)
        trace.pinch.append(pinch)
        trace.held_height.append(height)
        trace.centred.append(centred)
        if self._camera >= 0:
            frame = data.cam_xmat[self._camera]
            trace.camera_position.append(data.cam_xpos[self._camera].copy())
            trace.camera_view.append(-np.array([frame[2], frame[5], frame[8]]))
            trace.horizon_deg.append(laparoscope.horizon_of(frame))
        else:
            trace.camera_position.append(np.zeros(3))
            trace.camera_view.append(np.array([0.0, 0.0, -1.0]))
            trace.horizon_deg.append(0.0)
        worst, where, torn = damage_summary(physics.intestine(), data)
        trace.damage_max.append(worst)
        trace.damage_where_m.append(where)
        trace.perforations_where_m.append(torn)
        trace.success = bool(env.task.success(physics))
        return pinch_now

    def _touches_wall(self, model, data, tool: str) -> bool:
        """Geometric: tools and walls have no MuJoCo contacts (the shafts pass the anterior wall)."""
        for geom in self._geoms[tool]:
            for wall in self._walls:
                if mujoco.mj_geomDistance(model, data, geom, wall, WALL_CONTACT_M, None) < WALL_CONTACT_M:
                    return True
        return False


def _body_of_tool(model, body: int, tool: str) -> bool:
    """Whether `body` hangs below the tool's trocar body."""
    while body > 0:
        if model.body(body).name == f"{tool}_trocar":
            return True
        body = int(model.body_parentid[body])
    return False


def damage_summary(gut, data) -> tuple[float, float | None, list[float]]:
    """The bowel wall's damage now (docs/model.md#damage): the worst bruise (0 to 1), where it is
    (m along the rest axis from the first control point; None when unbruised) and the middle of
    each torn stretch of control points (m): one entry per perforation."""
    damage = gut.damage(data)
    spacing = gut.rest_length / max(1, len(damage) - 1)
    worst = int(np.argmax(damage[:, 0]))
    torn = np.flatnonzero(damage[:, 1] > 0.0)
    stretches = np.split(torn, np.flatnonzero(np.diff(torn) > 1) + 1) if torn.size else []
    return (float(damage[worst, 0]), worst * spacing if damage[worst, 0] > 0.0 else None,
            [float(stretch.mean() * spacing) for stretch in stretches])


def _grasp_events(holding: np.ndarray, closed: np.ndarray, height: np.ndarray) -> tuple[int, int, int]:
    """grasps (holds taken), slips (holds lost with the jaw still closed: the tissue pulled out)
    and drops (holds released by opening the jaw more than DROP_HEIGHT_M above the wall)."""
    grasps = slips = drops = 0
    for k in range(1, len(holding)):
        if holding[k] and not holding[k - 1]:
            grasps += 1
        elif holding[k - 1] and not holding[k]:
            if closed[k]:
                slips += 1
            elif height[k - 1] > DROP_HEIGHT_M:
                drops += 1
    return grasps, slips, drops


def _grasp_force_time_products(holding: np.ndarray, pinch: np.ndarray, dt: np.ndarray) -> list[float]:
    """Each hold's force-time product (N s): its pinch integrated over the ticks it lasts."""
    products, current = [], None
    for k in range(1, len(holding)):
        if holding[k]:
            current = (current or 0.0) + pinch[k] * dt[k - 1]
        elif current is not None:
            products.append(current)
            current = None
    if current is not None:
        products.append(current)
    return products


def score(trace: Trace) -> dict:
    """The episode's score (JSON-able; the module doc and docs/rehearsal.md define each entry)."""
    a = trace.arrays()
    time = a["time"]
    if len(time) < 2:
        raise ValueError("a trace needs at least two samples (after the reset, after a step)")
    centred = a["centred"] if len(a["centred"]) == len(time) else np.zeros((len(time), len(trace.tools)))
    dt = np.diff(time)
    tools = {}
    for i, tool in enumerate(trace.tools):
        tip, shaft, force = a["tip"][:, i], a["shaft"][:, i], a["force"][:, i]
        steps = np.linalg.norm(np.diff(tip, axis=0), axis=1)
        cosine = np.clip(np.sum(shaft[1:] * shaft[:-1], axis=1), -1.0, 1.0)
        magnitude = np.linalg.norm(force, axis=1)[1:]  # each tick's force, over the tick before it
        grasps, slips, drops = _grasp_events(a["holding"][:, i], a["jaw_closed"][:, i], a["held_height"][:, i])
        tools[tool] = {
            "path_length_m": float(steps.sum()),
            "angular_path_deg": float(np.degrees(np.arccos(cosine)).sum()),
            "idle_s": float(dt[steps / dt < IDLE_SPEED_M_S].sum()),
            "grasps": grasps, "slips": slips, "drops": drops,
            "wall_contact_s": float(dt[a["wall"][1:, i] > 0].sum()),
            "out_of_view_s": float(dt[(a["in_view"][1:, i] == 0) & (a["inside"][1:, i] > 0)].sum()),
            "centred_s": float(dt[(centred[1:, i] > 0) & (a["inside"][1:, i] > 0)].sum()),
            "peak_force_n": float(magnitude.max()),
            "rms_force_n": float(np.sqrt(np.sum(magnitude ** 2 * dt) / np.sum(dt))),
            "force_over_threshold_s": float(dt[magnitude > TRACTION_LIMIT_N].sum()),
        }
    pinch, holding = a["pinch"][1:], a["holding"][1:] > 0
    held_pinch = pinch[holding]
    products = [p for i in range(len(trace.tools))
                for p in _grasp_force_time_products(a["holding"][:, i], a["pinch"][:, i], dt)]
    tissue = {
        "peak_pinch_n": float(pinch.max()) if pinch.size else 0.0,
        "perforation_pinch_n": PERFORATION_PINCH_N,
        "mean_pinch_while_holding_n": float(held_pinch.mean()) if held_pinch.size else None,
        "slip_preventing_pinch_n": SLIP_PREVENTING_PINCH_N,
        "grip_beyond_slip_n": float(held_pinch.mean() - SLIP_PREVENTING_PINCH_N) if held_pinch.size else None,
        "grip_beyond_slip_s": float(np.sum(np.where(pinch > SLIP_PREVENTING_PINCH_N, dt[:, None], 0.0))),
        "force_time_product_ns": float(max(products)) if products else 0.0,
        "force_time_product_limit_ns": FORCE_TIME_PRODUCT_LIMIT_NS,
        "traction_limit_n": TRACTION_LIMIT_N,
        # the wall's own damage (plugin state): it only grows, so the last sample is the episode's
        "damage_max": float(trace.damage_max[-1]) if trace.damage_max else 0.0,
        "damage_where_m": trace.damage_where_m[-1] if trace.damage_where_m else None,
        "perforations": len(trace.perforations_where_m[-1]) if trace.perforations_where_m else 0,
        "perforations_where_m": list(trace.perforations_where_m[-1]) if trace.perforations_where_m else [],
    }
    costs = [step_cost_from(a["force"][k], a["pinch"][k]) for k in range(1, len(time))]
    camera = None  # a trace built by hand may leave the camera out
    if len(a["camera_view"]) == len(time):
        view, position, horizon = a["camera_view"], a["camera_position"], a["horizon_deg"]
        turns = np.clip((view[1:] * view[:-1]).sum(axis=1), -1.0, 1.0)
        camera = {"path_deg": float(np.degrees(np.arccos(turns)).sum()),
                  "travel_m": float(np.sqrt(((position[1:] - position[:-1]) ** 2).sum(axis=1)).sum()),
                  "horizon_off_s": float(dt[horizon[1:] >= HORIZON_TOLERANCE_DEG].sum()),
                  "mean_horizon_deg": float(np.sum(horizon[1:] * dt) / np.sum(dt))}
    return {"success": bool(trace.success), "time_s": float(time[-1] - time[0]), "tools": tools, "tissue": tissue,
            "camera": camera, "safety_cost": float(np.dot(costs, dt))}


def step_cost_from(forces: np.ndarray, pinches: np.ndarray) -> float:
    """The tissue-safety cost of one instant (0 when safe): one per tool pushing or pulling over
    TRACTION_LIMIT_N, one per jaw pinching over SLIP_PREVENTING_PINCH_N and one more over
    PERFORATION_PINCH_N. An indicator count, as safe-RL suites define a step's cost."""
    forces, pinches = np.atleast_2d(forces), np.atleast_1d(pinches)
    return float(np.count_nonzero(np.linalg.norm(forces, axis=1) > TRACTION_LIMIT_N)
                 + np.count_nonzero(pinches > SLIP_PREVENTING_PINCH_N) + np.count_nonzero(pinches > PERFORATION_PINCH_N))


def closing_angle(gut) -> float:
    """The jaw angle (rad) at or below which the plugin counts a jaw closed: config
    `grasp_closed_below`, 0.1 by default; the pinch model's meeting angle."""
    return float(gut.config.get("grasp_closed_below", 0.1))


def pinches(physics) -> dict[str, float]:
    """Each grasper's pinch now (N; the plugin's, Intestine.pinches), 0 for one not holding."""
    data = physics.data.ptr
    gut = physics.intestine()
    return {grasp.site.removesuffix("_tip"): (pinch or 0.0) if grasp.holding else 0.0
            for grasp, (pinch, _) in zip(gut.grasps(data), gut.pinches(data))}


def step_cost(physics) -> float:
    """step_cost_from the physics now (for gymnasium's info["cost"])."""
    forces = np.array([physics.named.data.sensordata[f"{t}_force"][:3] for t in physics.tools()])
    return step_cost_from(forces, np.array(list(pinches(physics).values())))


def assess(recording, progress: bool = False) -> dict:
    """The score of a recording (viscera.recording), by replaying it."""
    from viscera.recording import replay
    tracer = []

    def on_step(env, time_step) -> None:
        if not tracer:
            tracer.append(Tracer(env))
        tracer[0].sample(env)

    replay(recording, on_step=on_step, progress=progress)
    return score(tracer[0].trace)


def summary_lines(score: dict) -> list[str]:
    """The score for a terminal: a line per tool, then the tissue's."""
    lines = [f"score            {'success' if score['success'] else 'no success'} in {score['time_s']:.2f} s, "
             f"safety cost {score['safety_cost']:.2f}"]
    for tool, v in score["tools"].items():
        lines.append(f"{tool:16s} path {v['path_length_m']:.3f} m, angular {v['angular_path_deg']:.0f} deg, "
                     f"idle {v['idle_s']:.1f} s, grasps {v['grasps']} (slips {v['slips']}, drops {v['drops']}), "
                     f"wall {v['wall_contact_s']:.1f} s, out of view {v['out_of_view_s']:.1f} s, force peak "
                     f"{v['peak_force_n']:.2f} N rms {v['rms_force_n']:.2f} N, over {TRACTION_LIMIT_N:g} N "
                     f"{v['force_over_threshold_s']:.1f} s")
    c = score.get("camera")
    if c is not None:
        centred = ", ".join(f"{tool} {v['centred_s']:.1f} s" for tool, v in score["tools"].items())
        lines.append(f"camera           path {c['path_deg']:.0f} deg, travel {100 * c['travel_m']:.1f} cm, horizon off "
                     f"level (over {HORIZON_TOLERANCE_DEG:g} deg) {c['horizon_off_s']:.1f} s, mean "
                     f"{c['mean_horizon_deg']:.0f} deg; centred: {centred}")
    t = score["tissue"]
    mean = t["mean_pinch_while_holding_n"]
    lines.append(f"tissue           pinch peak {t['peak_pinch_n']:.1f} N (perforation {PERFORATION_PINCH_N:g} N), "
                 f"mean while holding {'-' if mean is None else f'{mean:.1f} N'} (slip prevented at "
                 f"{SLIP_PREVENTING_PINCH_N:g} N), force-time product {t['force_time_product_ns']:.1f} N s "
                 f"(damage above {FORCE_TIME_PRODUCT_LIMIT_NS:g})")
    where = t.get("damage_where_m")
    torn = ", ".join(f"{100 * w:.0f} cm" for w in t.get("perforations_where_m", []))
    lines.append(f"wall             bruise {t.get('damage_max', 0.0):.2f} of 1"
                 + (f" at {100 * where:.0f} cm along the bowel" if where is not None else "")
                 + f", perforations {t.get('perforations', 0)}" + (f" at {torn}" if torn else ""))
    return lines
