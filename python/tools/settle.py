"""Settle the intestine into the abdominal cavity and write its rest shape into the scene.

    python python/tools/settle.py --out settled.xml [--scene assets/scenes/abdomen.xml] [--duration 6]
    python python/tools/settle.py --out assets/scenes/abdomen.xml    # update the shipped scene

The scene's intestine is laid out as two serpentines side by side: the first
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
import pathlib
import re
import sys

import viscera  # first: headless GL backend

import mujoco  # noqa: E402
import numpy as np  # noqa: E402
from tqdm import tqdm  # noqa: E402

from viscera import cli  # noqa: E402

SCENE = pathlib.Path("assets") / "scenes" / "abdomen.xml"  # run from the repository root
DURATION = 6.0  # s: the shipped scene was settled with it (a rerun reproduces its points to the digit)
HALF_WIDTH = (0.15, 0.125)  # the cavity's inner half sizes along x and y (m)
LAYER_PITCH_RADII = 4.0     # rows and layers 4 radii apart: one tube diameter of clearance
SETTLING_PHYSICS = {"integrator": "rk4", "mass_matrix": "consistent"}  # config keys, where the scene has none
BANK = pathlib.Path("assets") / "scenes" / "abdomen_starts.npz"  # the tasks' settled starts


def _serpentine(x_outer: float, x_inner: float, y_first: float, y_last: float, rows: int, radius: float,
                layers: int) -> np.ndarray:
    """Vertices of a serpentine from the corner (x_outer, y_first) on the wall: rows along x
    between x_outer and x_inner, stepping along y to y_last, then back on the next layer up."""
    points = []
    x_from, x_to = x_outer, x_inner
    for layer in range(layers):
        z = radius + layer * LAYER_PITCH_RADII * radius
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


def initial_path(length: float, radius: float, layout: int = 0) -> np.ndarray:
    """The two-serpentine polyline (m, (k, 3)) of `length` m, both ends on the wall. Layout 0 is
    the shipped scene's; layout k > 0 draws its own (seeded by k): the rows' pitch (4 to 5.2
    radii) and the halves' inner edges (up to 3 cm off the midline), as wide as the cavity holds, and
    each interior vertex moved by up to 1 cm across the rows, so that each settles into its own
    pile of loops."""
    rng = np.random.default_rng(layout) if layout else None
    pitch = LAYER_PITCH_RADII * (rng.uniform(1.0, 1.3) if rng else 1.0)
    inner_shift = rng.uniform(0.0, 0.03, 2) if rng else np.zeros(2)
    while True:
        try:
            return _two_serpentines(length, radius, pitch, inner_shift, rng)
        except ValueError:  # too wide to hold the length: closer rows, then halves nearer the midline
            if pitch <= LAYER_PITCH_RADII and inner_shift.max() < 1e-3:
                raise
            if pitch > LAYER_PITCH_RADII:
                pitch = max(LAYER_PITCH_RADII, 0.97 * pitch)
            else:
                inner_shift = 0.5 * inner_shift


def _two_serpentines(length: float, radius: float, pitch: float, inner_shift: np.ndarray,
                     rng: np.random.Generator | None) -> np.ndarray:
    clearance = radius + 0.002  # from the walls
    x_outer, x_inner = HALF_WIDTH[0] - clearance, 0.5 * pitch * radius
    y_far = HALF_WIDTH[1] - clearance
    rows = int((2.0 * y_far) // (pitch * radius)) + 1
    left = _serpentine(-x_outer, -x_inner - inner_shift[0], y_far, -y_far, rows, radius, layers=2)  # left cranial
    right = _serpentine(x_outer, x_inner + inner_shift[1], -y_far, y_far, rows, radius, layers=2)   # right caudal
    if rng is not None:  # the ends stay on their corners
        for half in (left, right):
            half[1:, 1] = np.clip(half[1:, 1] + rng.uniform(-0.01, 0.01, len(half) - 1), -y_far, y_far)
    crossing = 0.0
    for _ in range(100):  # the crossing's length depends on where the halves end
        half = 0.5 * (length - crossing)
        a, b = _first(left, half), _first(right, half)
        top = max(a[-1, 2], b[-1, 2]) + LAYER_PITCH_RADII * radius  # over the top layer
        path = np.vstack([a, [a[-1, 0], a[-1, 1], top], [b[-1, 0], b[-1, 1], top], b[::-1]])
        total = float(np.linalg.norm(np.diff(path, axis=0), axis=1).sum())
        if abs(total - length) < 1e-10:
            break
        crossing = total - 2.0 * half
    if total < length:  # not converged to the last 1e-10: raise the crossing by what is missing
        path[len(a):len(a) + 2, 2] += 0.5 * (length - total) + 1e-9
    return path


def settle(scene: pathlib.Path, duration: float, quiet: bool = False, layout: int = 0) -> np.ndarray:
    """Drop the initial path (`layout`, see initial_path) into the scene's cavity; return the
    settled control points (m, (n, 3))."""
    text = scene.read_text()
    probe = mujoco.MjModel.from_xml_string(_with_shape(text, "line", None))
    gut = viscera.intestine(probe)
    try:
        path = initial_path(gut.rest_length, gut.radius, layout)
    except ValueError as error:  # an intestine too long for this cavity: the user's scene, found before stepping
        raise cli.UserError(f"{scene}: {error}") from error
    model = mujoco.MjModel.from_xml_string(_with_settling_physics(_with_shape(text, "polyline", path)))
    data = mujoco.MjData(model)
    gut = viscera.intestine(model)
    mujoco.mj_forward(model, data)
    steps = int(round(duration / model.opt.timestep))
    for _ in tqdm(range(steps), desc="settling", unit="step", disable=quiet):
        mujoco.mj_step(model, data)
    speed = float(np.abs(gut.velocities(data)).max())
    if not quiet:
        print(f"settled after {duration:g} s: fastest control point {speed * 1000:.2f} mm/s, "
              f"divergences {gut.divergence_count(data)}, length {gut.length(data):.4f} m")
    if gut.divergence_count(data) or speed > 0.01:
        raise RuntimeError(f"the intestine has not come to rest (fastest point {speed:.3g} m/s); settle longer")
    return gut.positions(data).copy()


def _with_settling_physics(text: str) -> str:
    """The scene text with SETTLING_PHYSICS's keys added to the intestine where it sets none, and
    sleeping off (it settles to rest, not to below the sleep speed; RK4 with the consistent
    matrix cannot sleep anyway)."""
    text = re.sub(r'<config key="sleep" value="[^"]*"/>', '<config key="sleep" value="0"/>', text)
    added = "".join(f'<config key="{key}" value="{value}"/>' for key, value in SETTLING_PHYSICS.items()
                    if f'<config key="{key}"' not in text)
    text, count = re.subn(r'(<instance name="[^"]*">)', lambda match: match.group(1) + added, text, count=1)
    if count != 1:
        raise ValueError("the scene must hold the intestine's plugin instance")
    return text


def _with_shape(text: str, shape: str, points: np.ndarray | None, digits: int = 12) -> str:
    """The scene text with the intestine's `shape` and `points` configs replaced (m, to 10^-digits)."""
    value = "" if points is None else " ".join(f"{x:.{digits}f}" for x in np.asarray(points).ravel())
    text, shapes = re.subn(r'<config key="shape" value="[^"]*"/>', f'<config key="shape" value="{shape}"/>', text)
    text, pointss = re.subn(r'<config key="points" value="[^"]*"/>', f'<config key="points" value="{value}"/>', text)
    if shapes != 1 or pointss != 1:
        raise ValueError("the scene must hold exactly one intestine 'shape' and one 'points' config")
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
    parser.add_argument("--duration", type=cli.duration, default=DURATION,
                        help=f"settling time (simulated s, default {DURATION:g}: the shipped scene's)")
    parser.add_argument("--bank", type=cli.positive_int, metavar="K",
                        help="instead of a scene, settle layouts 1 to K and write their control points to --out "
                             f"(.npz, key 'control_points' (K, n, 3) m): the tasks' bank of starts ({BANK})")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    parser.add_argument("--verbose", action="store_true", help="print the traceback of an error too")
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    with cli.user_errors("settle.py", args.verbose):
        cli.load_model(args.scene)  # the scene as given loads, before a long settle
        text = args.scene.read_text()
        try:
            _with_shape(text, "line", None)
        except ValueError as error:
            raise cli.UserError(f"{args.scene}: {error}") from error
        if args.bank and not str(args.out).endswith(".npz"):
            raise cli.UserError(f"--out {args.out}: --bank writes a .npz")
        if not args.bank and str(args.out).endswith(".npz"):
            raise cli.UserError(f"--out {args.out}: a scene is written as .xml (a .npz needs --bank)")
        try:
            if args.bank:
                starts = np.stack([settle(args.scene, args.duration, True, layout)
                                   for layout in tqdm(range(1, args.bank + 1), desc="layouts", disable=args.quiet)])
                np.savez_compressed(args.out, control_points=np.round(starts, 6))
                print(f"wrote {len(starts)} settled starts of {starts.shape[1]} control points into {args.out}")
                return 0
            settled = settle(args.scene, args.duration, args.quiet)
        except RuntimeError as error:  # not at rest: settle's verdict on the user's --duration
            raise cli.UserError(str(error)) from error
        pathlib.Path(args.out).write_text(_with_shape(text, "control_points", settled, digits=6))
    print(f"wrote {len(settled)} settled control points into {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
