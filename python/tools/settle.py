"""Settle the intestine into the abdominal cavity and write its rest shape into the scene.

    python python/tools/settle.py --out settled.xml [--scene assets/scenes/abdomen.xml] [--duration 6]
    python python/tools/settle.py --out assets/scenes/abdomen.xml    # update the shipped scene
    python python/tools/settle.py --scene assets/scenes/abdomen_anatomical.xml --out assets/scenes/abdomen_anatomical.xml
    python python/tools/settle.py --scene assets/scenes/abdomen_anatomical.xml --bank 24 \
        --out assets/scenes/abdomen_anatomical_starts.npz                # its bank of starts

A scene's bowel (its intestine, or the one its cavity names) is laid out as two serpentines side by side: the first
half rises from the duodenojejunal flexure (its pinned first point, on the
posterior wall at the left cranial corner) through two layers in the left half
of the cavity, crosses over the midline above them, and the second half comes
down two layers in the right half to the ileocaecal junction (its pinned last
point, on the posterior wall at the right caudal corner). Both ends thus start
on the wall. The tools stay withdrawn while it falls and comes to rest; the
settled control points then replace the `points` config of the scene (shape
`control_points`), so every episode starts from rest without re-simulating.
The run is deterministic: rerunning it rewrites the same shape.

The fall to rest is chaotic: a change of integrator or mass matrix lands the
loops elsewhere. Both leave the statics alone (the rest shape is an
equilibrium under every integrator and mass matrix), so the settling run uses
fixed physics, RK4 with the consistent mass matrix (SETTLING_PHYSICS, where the
scene does not set them), and the shipped scene stays reproducible when the
defaults change.
"""

from __future__ import annotations

import argparse
import dataclasses
import pathlib
import re
import sys
from collections.abc import Callable

import viscera  # first: headless GL backend

import mujoco  # noqa: E402
import numpy as np  # noqa: E402
from tqdm import tqdm  # noqa: E402

from viscera import cli  # noqa: E402

import posterior_wall  # noqa: E402

SCENE = pathlib.Path("assets") / "scenes" / "abdomen.xml"  # run from the repository root
DURATION = 6.0  # s: the shipped box abdomen was settled with it (a rerun reproduces its points to the digit)
HALF_WIDTH = (0.15, 0.125)  # the cavity's inner half sizes along x and y (m)
LAYER_PITCH_RADII = 4.0     # rows and layers 4 radii apart: one tube diameter of clearance
REST_WINDOW_S, REST_SPEED = 0.1, 0.01  # s, m/s: at rest, every control point moved less than 1 mm in 0.1 s
SETTLING_PHYSICS = {"integrator": "rk4", "mass_matrix": "consistent"}  # config keys, where the scene has none
BANK = pathlib.Path("assets") / "scenes" / "abdomen_starts.npz"  # the tasks' settled starts


def _serpentine(x_outer: float, x_inner: float, y_first: float, y_last: float, rows: int, radius: float,
                layers: int, pitch_radii: float = LAYER_PITCH_RADII) -> np.ndarray:
    """Vertices of a serpentine from the corner (x_outer, y_first) on the wall: rows along x
    between x_outer and x_inner, stepping along y to y_last, then back on the next layer up."""
    points = []
    x_from, x_to = x_outer, x_inner
    for layer in range(layers):
        z = radius + layer * pitch_radii * radius
        ys = np.linspace(y_first, y_last, rows)
        for y in (ys if layer % 2 == 0 else ys[::-1]):
            points += [(x_from, y, z), (x_to, y, z)]
            x_from, x_to = x_to, x_from
    return np.array(points)


def _first(path: np.ndarray, length: float) -> np.ndarray:
    """The first `length` m of a polyline."""
    segment = np.linalg.norm(np.diff(path, axis=0), axis=1)
    cumulative = np.concatenate([[0.0], np.cumsum(segment)])
    if cumulative[-1] < length:
        raise ValueError(f"the cavity holds {cumulative[-1]:.2f} m per half, {length:.2f} m asked")
    k = int(np.searchsorted(cumulative, length))
    end = path[k - 1] + (length - cumulative[k - 1]) / segment[k - 1] * (path[k] - path[k - 1])
    return np.vstack([path[:k], end])


@dataclasses.dataclass(frozen=True)
class Cavity:
    """Where a scene's bowel is laid out before it falls: the pile's half sizes and centre (m, x y),
    layers per half, rows and layers `pitch_radii` radii apart, the posterior wall's height (m) at
    (x, y) (None: flat, at 0), the instance laid out (None: the scene's only one) and the other
    instances' initial polylines (m, (k, 3)), which fall with it."""

    half_width: tuple[float, float] = HALF_WIDTH
    centre: tuple[float, float] = (0.0, 0.0)
    layers: int = 2
    pitch_radii: float = LAYER_PITCH_RADII
    floor: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None
    bowel: str | None = None
    others: tuple[tuple[str, tuple[float, ...]], ...] = ()
    duration: float = DURATION  # s: the default settling time, the shipped scene's


COLON_RADIUS = 0.025  # m, the anatomical abdomen's colon


def _resting_height(x: float, y: float, radius: float) -> float:
    """The height (m) of a sphere's centre of `radius` (m) resting at (x, y) on the anatomical
    abdomen's posterior wall (python/tools/posterior_wall.py), 2.5 mm clear of it (the
    heightfield's facets lie up to 1.5 mm off the wall's function on the steep caecal slope)."""
    u = np.linspace(-radius, radius, 21)
    dx, dy = np.meshgrid(u, u)
    inside = dx ** 2 + dy ** 2 <= radius ** 2
    tops = posterior_wall.wall_height(x + dx[inside], y + dy[inside]) + np.sqrt(radius ** 2 - dx[inside] ** 2 -
                                                                                  dy[inside] ** 2)
    return float(tops.max()) + 0.0025


def _colon_sections() -> list[tuple[str, list[tuple[float, float, float]], list[bool]]]:
    """colon_path's sections in order: each one's name, vertices (m) and which of them lie on the
    wall (a fold's lows, every vertex of the retroperitoneal parts)."""
    def resting(x: float, y: float, lift: float = 0.0) -> tuple[float, float, float]:
        return x, y, _resting_height(x, y, COLON_RADIUS) + lift

    def folds(xs: np.ndarray, y: float, lift: float, first_low: int) -> tuple[list, list[bool]]:
        lows = [(i + first_low) % 2 == 0 for i in range(len(xs))]
        return [resting(x, y, 0.0 if low else lift) for x, low in zip(xs, lows)], lows

    ascending = [resting(0.14, y) for y in np.linspace(-0.125, 0.115, 13)]
    transverse, transverse_lows = folds(np.linspace(0.11, -0.11, 9), 0.135, 0.055, 0)
    descending = [resting(-0.14, y) for y in np.linspace(0.12, -0.10, 12)]
    sigmoid, sigmoid_lows = folds(np.linspace(-0.115, 0.035, 7), -0.13, 0.045, 1)
    return [("ascending", ascending, [True] * len(ascending)), ("transverse", transverse, transverse_lows),
            ("descending", descending, [True] * len(descending)), ("sigmoid", sigmoid, sigmoid_lows),
            ("rectum", [resting(0.0, -0.15)], [True])]


def colon_path() -> np.ndarray:
    """The colon's initial polyline (m, (k, 3)) in the anatomical abdomen, 1.44 m: an adult's
    length (about 1.5 m in textbook anatomy, its sections about 20 cm ascending with the caecum,
    46 cm transverse, 25 cm descending and 35 to 40 cm sigmoid). The caecum's pole lies at the
    right caudal corner and the ascending colon runs up the right flank, resting on the posterior
    wall every 2 cm (retroperitoneal: the scene pins these points), 0.25 m; the transverse colon,
    0.52 m with both flexures, crosses the cranial edge from the hepatic flexure, its redundancy
    in folds that rise 5.5 cm and fall onto each other there, where a surgeon lifts it to reach
    the small bowel; the descending colon runs down the left flank, resting on the wall like the
    ascending, 0.23 m; the sigmoid with the rectum, 0.42 m, folds across the caudal edge to the
    rectum's end on the pelvic brim. Both folds' strips lie beyond the small bowel's lay region and the tasks'
    targets (y beyond +-0.115 m)."""
    return np.array([vertex for _, vertices, _ in _colon_sections() for vertex in vertices])


def colon_pins(control_count: int) -> list[int]:
    """The colon's pinned control points when `control_count` of them lie evenly along colon_path:
    those on the ascending and the descending colon, the one nearest each fold's low vertex of the
    transverse and the sigmoid colon (their mesocolons' roots), and the last (the rectum)."""
    path = colon_path()
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(path, axis=0), axis=1))])
    at = arc / arc[-1] * (control_count - 1)  # each vertex's place in control-point spacings
    pins, first = set(), 0
    for name, vertices, lows in _colon_sections():
        span = range(first, first + len(vertices))
        if name in ("ascending", "descending"):  # every point along them
            pins |= {k for k in range(control_count) if at[span[0]] - 1e-9 <= k <= at[span[-1]] + 1e-9}
        elif name in ("transverse", "sigmoid"):  # the point nearest each fold's low
            pins |= {int(round(at[v])) for v, low in zip(span, lows) if low}
        first += len(vertices)
    return sorted(pins) + [-1]


# The anatomical abdomen (assets/scenes/abdomen_anatomical.xml): the small bowel in three layers
# inside the colon's frame (x within 10 cm of the midline, y from 8.5 cm caudal, clear of the
# sigmoid, to 10 cm cranial, clear of the transverse colon), on the curved posterior wall; the
# colon from colon_path.
ANATOMICAL = Cavity(
    half_width=(0.1125, 0.105), centre=(0.0, 0.0075), layers=3, pitch_radii=2.4, floor=posterior_wall.wall_height,
    bowel="small_bowel", duration=8.0, others=(("colon", tuple(colon_path().ravel())),))
CAVITIES = {"abdomen_anatomical": ANATOMICAL}  # by the scene's model name; any other: the box abdomen's


def cavity_of(text: str) -> Cavity:
    """The layout of the scene `text` (its <mujoco model=...>), the box abdomen's by default."""
    match = re.search(r'<mujoco\s+model="([^"]*)"', text)
    return CAVITIES.get(match.group(1) if match else "", Cavity())


def initial_path(length: float, radius: float, layout: int = 0, cavity: Cavity = Cavity()) -> np.ndarray:
    """The two-serpentine polyline (m, (k, 3)) of `length` m, both ends on the wall. Layout 0 is
    the shipped scene's; layout k > 0 draws its own (seeded by k): the rows' pitch (1 to 1.3 times
    the cavity's) and the halves' inner edges (up to 3 cm off the midline), as wide as the cavity
    holds, and each interior vertex moved by up to 1 cm across the rows, so that each settles
    into its own pile of loops."""
    rng = np.random.default_rng(layout) if layout else None
    pitch = cavity.pitch_radii * (rng.uniform(1.0, 1.3) if rng else 1.0)
    inner_shift = rng.uniform(0.0, 0.03, 2) if rng else np.zeros(2)
    while True:
        try:
            return _two_serpentines(length, radius, pitch, inner_shift, rng, cavity)
        except ValueError:  # too wide to hold the length: closer rows, then halves nearer the midline
            if pitch <= cavity.pitch_radii and inner_shift.max() < 1e-3:
                raise
            if pitch > cavity.pitch_radii:
                pitch = max(cavity.pitch_radii, 0.97 * pitch)
            else:
                inner_shift = 0.5 * inner_shift


def _on_floor(half: np.ndarray, floor, step: float = 0.01) -> np.ndarray:
    """A serpentine's vertices with its rows cut into pieces of at most `step` m, each raised by
    the wall's height under it (floor(x, y), m)."""
    points = [half[0]]
    for a, b in zip(half[:-1], half[1:]):
        pieces = max(1, int(np.ceil(np.linalg.norm(b[:2] - a[:2]) / step)))
        points += [a + (b - a) * k / pieces for k in range(1, pieces + 1)]
    points = np.array(points)
    points[:, 2] += floor(points[:, 0], points[:, 1]) + 0.003  # the heightfield's facets are up to 3 mm off it
    return points


def _two_serpentines(length: float, radius: float, pitch: float, inner_shift: np.ndarray,
                     rng: np.random.Generator | None, cavity: Cavity = Cavity()) -> np.ndarray:
    clearance = radius + 0.002  # from the walls
    x_outer, x_inner = cavity.half_width[0] - clearance, 0.5 * pitch * radius
    y_far = cavity.half_width[1] - clearance
    rows = int((2.0 * y_far) // (pitch * radius)) + 1
    layers, pitch_radii = cavity.layers, cavity.pitch_radii
    left = _serpentine(-x_outer, -x_inner - inner_shift[0], y_far, -y_far, rows, radius, layers, pitch_radii)
    right = _serpentine(x_outer, x_inner + inner_shift[1], -y_far, y_far, rows, radius, layers, pitch_radii)
    if rng is not None:  # the ends stay on their corners
        for half in (left, right):
            half[1:, 1] = np.clip(half[1:, 1] + rng.uniform(-0.01, 0.01, len(half) - 1), -y_far, y_far)
    for half in (left, right):
        half[:, :2] += cavity.centre
    if cavity.floor is not None:
        left, right = _on_floor(left, cavity.floor), _on_floor(right, cavity.floor)
    crossing = 0.0
    for _ in range(100):  # the crossing's length depends on where the halves end
        half = 0.5 * (length - crossing)
        a, b = _first(left, half), _first(right, half)
        top = max(a[-1, 2], b[-1, 2]) + pitch_radii * radius  # over the top layer
        path = np.vstack([a, [a[-1, 0], a[-1, 1], top], [b[-1, 0], b[-1, 1], top], b[::-1]])
        total = float(np.linalg.norm(np.diff(path, axis=0), axis=1).sum())
        if abs(total - length) < 1e-10:
            break
        crossing = total - 2.0 * half
    if total < length:  # not converged to the last 1e-10: raise the crossing by what is missing
        path[len(a):len(a) + 2, 2] += 0.5 * (length - total) + 1e-9
    return path


def settle(scene: pathlib.Path, duration: float, quiet: bool = False, layout: int = 0) -> dict[str, np.ndarray]:
    """Drop the initial paths (`layout`, see initial_path; the cavity's other instances from their
    polylines) into the scene's cavity; return each instance's settled control points (m, (n, 3)),
    by name, the laid-out bowel first."""
    text = scene.read_text()
    cavity = cavity_of(text)
    shapes = {cavity.bowel: ("line", None)} | {name: ("line", None) for name, _ in cavity.others}
    probe = mujoco.MjModel.from_xml_string(_with_shapes(text, shapes))
    gut = viscera.intestine(probe, cavity.bowel)
    try:
        # rows pitched by the mean radius: a tapered bowel's (a row of jejunum lies beside a row of ileum)
        path = initial_path(gut.rest_length, 0.5 * (gut.radius + gut.radius_end), layout, cavity)
    except ValueError as error:  # an intestine too long for this cavity: the user's scene, found before stepping
        raise cli.UserError(f"{scene}: {error}") from error
    shapes = {cavity.bowel: ("polyline", path)} | {
        name: ("polyline", np.reshape(points, (-1, 3))) for name, points in cavity.others}
    model = mujoco.MjModel.from_xml_string(_with_settling_physics(_with_shapes(text, shapes)))
    data = mujoco.MjData(model)
    guts = [viscera.intestine(model, cavity.bowel)] + [viscera.intestine(model, name) for name, _ in cavity.others]
    mujoco.mj_forward(model, data)
    steps = int(round(duration / model.opt.timestep))
    window = min(steps, int(round(REST_WINDOW_S / model.opt.timestep)))
    before = {}
    for step in tqdm(range(steps), desc="settling", unit="step", disable=quiet):
        if step == steps - window:
            before = {gut.name: gut.positions(data).copy() for gut in guts}
        mujoco.mj_step(model, data)
    settled = {}
    for gut in guts:
        # at rest: no control point moved more than REST_SPEED x the window over its last
        # REST_WINDOW_S (a speed read at one instant would count a micrometre's jitter)
        speed = float(np.linalg.norm(gut.positions(data) - before[gut.name], axis=1).max()) / (window * model.opt.timestep)
        if not quiet:
            print(f"{gut.name}: settled after {duration:g} s: fastest control point {speed * 1000:.2f} mm/s over the "
                  f"last {REST_WINDOW_S:g} s, divergences {gut.divergence_count(data)}, length {gut.length(data):.4f} m")
        if gut.divergence_count(data) or speed > REST_SPEED:
            raise RuntimeError(f"{gut.name} has not come to rest (fastest point {speed:.3g} m/s over the last "
                               f"{REST_WINDOW_S:g} s); settle longer")
        settled[gut.name] = gut.positions(data).copy()
    return settled


def _with_settling_physics(text: str) -> str:
    """The scene text with SETTLING_PHYSICS's keys added to every intestine where it sets none,
    and sleeping off (it settles to rest, not to below the sleep speed; RK4 with the consistent
    matrix cannot sleep anyway)."""
    text = re.sub(r'<config key="sleep" value="[^"]*"/>', '<config key="sleep" value="0"/>', text)

    def add(match: re.Match) -> str:
        block = match.group(0)
        added = "".join(f'<config key="{key}" value="{value}"/>' for key, value in SETTLING_PHYSICS.items()
                        if f'<config key="{key}"' not in block)
        return match.group(1) + added + block[len(match.group(1)):]

    text, count = re.subn(r'(<instance name="[^"]*">).*?</instance>', add, text, flags=re.S)
    if count < 1:
        raise ValueError("the scene must hold the intestine's plugin instance")
    return text


def _with_shape(text: str, shape: str, points: np.ndarray | None, digits: int = 12,
                instance: str | None = None) -> str:
    """The scene text with the intestine's `shape` and `points` configs replaced (m, to 10^-digits):
    of the instance called `instance`, or of the scene's only one."""
    value = "" if points is None else " ".join(f"{x:.{digits}f}" for x in np.asarray(points).ravel())
    blocks = list(re.finditer(r'<instance name="([^"]*)">.*?</instance>', text, flags=re.S))
    if instance is not None:
        blocks = [block for block in blocks if block.group(1) == instance]
    if len(blocks) != 1:
        raise ValueError("the scene must hold exactly one intestine 'shape' and one 'points' config"
                         + (f" in its instance {instance!r}" if instance else ""))
    block = blocks[0].group(0)
    block, shapes = re.subn(r'<config key="shape" value="[^"]*"/>', f'<config key="shape" value="{shape}"/>', block)
    block, pointss = re.subn(r'<config key="points" value="[^"]*"/>', f'<config key="points" value="{value}"/>',
                             block)
    if shapes != 1 or pointss != 1:
        raise ValueError("the scene must hold exactly one intestine 'shape' and one 'points' config"
                         + (f" in its instance {instance!r}" if instance else ""))
    return text[:blocks[0].start()] + block + text[blocks[0].end():]


def _with_shapes(text: str, shapes: dict[str | None, tuple[str, np.ndarray | None]], digits: int = 12) -> str:
    """The scene text with each named instance's shape and points replaced (see _with_shape)."""
    for name, (shape, points) in shapes.items():
        text = _with_shape(text, shape, points, digits, name)
    return text


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python python/tools/settle.py",
        description="Settle the intestine into the abdominal cavity and write the scene with its rest shape "
                    "to --out (required: nothing is written without it).",
        epilog=f"To update the shipped scene, name it: --out {SCENE}")
    parser.add_argument("--out", type=cli.output_file(".xml", ".npz"), required=True,
                        help="where to write the scene with the settled shape (may be --scene itself), or the "
                             "bank (.npz) with --bank")
    parser.add_argument("--scene", type=pathlib.Path, default=SCENE,
                        help=f"scene to settle (default: {SCENE}, from the repository root)")
    parser.add_argument("--duration", type=cli.duration,
                        help=f"settling time (simulated s, default the shipped scene's: {DURATION:g} for the box "
                             f"abdomen, {ANATOMICAL.duration:g} for the anatomical one)")
    parser.add_argument("--bank", type=cli.positive_int, metavar="K",
                        help="instead of a scene, settle layouts 1, 2, ... until K have come to rest (those that "
                             "do not are left out, and said so) and write their control points to --out (.npz, key "
                             "'control_points' (K, n, 3) m, each other intestine's under '<name>_control_points', the "
                             f"layouts under 'layouts'): the tasks' bank of starts ({BANK})")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    parser.add_argument("--verbose", action="store_true", help="print the traceback of an error too")
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    with cli.user_errors("settle.py", args.verbose):
        cli.load_model(args.scene)  # the scene as given loads, before a long settle
        text = args.scene.read_text()
        cavity = cavity_of(text)
        if args.duration is None:
            args.duration = cavity.duration
        try:
            _with_shapes(text, {cavity.bowel: ("line", None)} | {name: ("line", None) for name, _ in cavity.others})
        except ValueError as error:
            raise cli.UserError(f"{args.scene}: {error}") from error
        if args.bank and not str(args.out).endswith(".npz"):
            raise cli.UserError(f"--out {args.out}: --bank writes a .npz")
        if not args.bank and str(args.out).endswith(".npz"):
            raise cli.UserError(f"--out {args.out}: a scene is written as .xml (a .npz needs --bank)")
        try:
            if args.bank:
                layouts, kept, skipped = [], [], []
                with tqdm(total=args.bank, desc="layouts", disable=args.quiet) as bar:
                    for layout in range(1, 2 * args.bank + 1):  # those that come to rest, up to K
                        try:
                            layouts.append(settle(args.scene, args.duration, True, layout))
                        except RuntimeError as error:
                            skipped.append(f"{layout} ({error})")
                            continue
                        kept.append(layout)
                        bar.update(1)
                        if len(kept) == args.bank:
                            break
                if len(kept) < args.bank:
                    raise cli.UserError(f"only {len(kept)} of the first {2 * args.bank} layouts came to rest in "
                                        f"{args.duration:g} s; settle longer")
                names = list(layouts[0])
                starts = {name: np.round(np.stack([each[name] for each in layouts]), 6) for name in names}
                arrays = {"control_points": starts[names[0]], "layouts": np.array(kept)} | {
                    f"{name}_control_points": starts[name] for name in names[1:]}
                np.savez_compressed(args.out, **arrays)
                for layout in skipped:
                    print(f"left out layout {layout}")
                print(f"wrote {len(layouts)} settled starts of {', '.join(str(len(starts[n][0])) for n in names)} "
                      f"control points into {args.out}")
                return 0
            settled = settle(args.scene, args.duration, args.quiet)
        except RuntimeError as error:  # not at rest: settle's verdict on the user's --duration
            raise cli.UserError(str(error)) from error
        shapes = {(name if len(settled) > 1 else None): ("control_points", points) for name, points in settled.items()}
        pathlib.Path(args.out).write_text(_with_shapes(text, shapes, digits=6))
    print(f"wrote {', '.join(str(len(points)) for points in settled.values())} settled control points into {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
