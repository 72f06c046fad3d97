"""Write the anatomical abdomen's posterior wall (a MuJoCo heightfield) into its scene.

    python python/tools/posterior_wall.py [--scene assets/scenes/abdomen_anatomical.xml]

The wall is a bowl, in metres above its lowest level (x: the patient's left to right, y: caudal
to cranial):
- the lumbar spine and the psoas muscles, a ridge along the midline, SPINE_HEIGHT_M high and
  SPINE_WIDTH_M wide (a Gaussian), under the mesentery's root;
- the flanks, the diaphragm and the pelvic brim, where the wall curves up: beyond a rounded
  rectangle (a superellipse of half sizes FLOOR_HALF_M, exponent 4) the wall rises as the square
  of the distance past RISE_FROM of it, RISE_M higher at RISE_TO.
The heightfield's `elevation` attribute (nrow x ncol numbers in [0, 1], scaled by its size's
third number) is rewritten in place; the rest of the scene is left as it is.
"""

from __future__ import annotations

import argparse
import pathlib
import re
import sys

import numpy as np

SCENE = pathlib.Path("assets") / "scenes" / "abdomen_anatomical.xml"
SPINE_HEIGHT_M, SPINE_WIDTH_M = 0.015, 0.04
FLOOR_HALF_M = (0.175, 0.16)
RISE_FROM, RISE_TO, RISE_M = 0.8, 1.2, 0.10


def wall_height(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """The wall's height (m) above its lowest level at (x, y) (m)."""
    spine = SPINE_HEIGHT_M * np.exp(-(np.asarray(x) / SPINE_WIDTH_M) ** 2)
    rho = ((np.asarray(x) / FLOOR_HALF_M[0]) ** 4 + (np.asarray(y) / FLOOR_HALF_M[1]) ** 4) ** 0.25
    rise = RISE_M * np.clip((rho - RISE_FROM) / (RISE_TO - RISE_FROM), 0.0, 1.0) ** 2
    return spine + rise


def elevation(half_x: float, half_y: float, rows: int, columns: int) -> tuple[np.ndarray, float]:
    """The heightfield's rows x columns heights (m) over [-half_x, half_x] x [-half_y, half_y]
    (MuJoCo's order: row 0 at -y, column 0 at -x) and their maximum (m)."""
    x, y = np.meshgrid(np.linspace(-half_x, half_x, columns), np.linspace(-half_y, half_y, rows))
    heights = wall_height(x, y)
    return heights, float(heights.max())


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python python/tools/posterior_wall.py", description=__doc__.split("\n")[0])
    parser.add_argument("--scene", type=pathlib.Path, default=SCENE, help=f"the scene to rewrite (default {SCENE})")
    args = parser.parse_args(argv)
    if not args.scene.is_file():
        print(f"posterior_wall.py: --scene {args.scene}: no such file", file=sys.stderr)
        return 2
    text = args.scene.read_text()
    pattern = re.compile(r'<hfield name="posterior_wall" nrow="(\d+)" ncol="(\d+)" size="([^"]+)"\s+elevation="[^"]*"/>')
    match = pattern.search(text)
    if match is None:
        print(f"posterior_wall.py: --scene {args.scene}: no <hfield name=\"posterior_wall\" nrow ncol size "
              "elevation/> in it", file=sys.stderr)
        return 2
    rows, columns = int(match.group(1)), int(match.group(2))
    size = [float(v) for v in match.group(3).split()]
    heights, top = elevation(size[0], size[1], rows, columns)
    if abs(top - size[2]) > 1e-9:
        print(f"posterior_wall.py: the hfield's size[2] must be the wall's height {top:.6f} m, not {size[2]}",
              file=sys.stderr)
        return 2
    values = " ".join(f"{v:.4f}" for v in (heights / top).ravel())
    text = text[:match.start()] + (f'<hfield name="posterior_wall" nrow="{rows}" ncol="{columns}" '
                                   f'size="{match.group(3)}"\n            elevation="{values}"/>') + text[match.end():]
    args.scene.write_text(text)
    print(f"wrote the posterior wall's {rows} x {columns} heights (up to {top:.4f} m) into {args.scene}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
