"""Contacts that follow the tube: how the chain of collision spheres meets a tool, a slope, a pile
and the clock, against the spacing of its spheres (one radius apart by default; the `tolerance`
spaces them by their sagitta).

    python python/tools/validation/contacts/study.py [--quick] [--out docs/validation]

- Ripple: a 1 m tube lies on a plane; a capsule tool (5 mm radius) across it, held 2 mm into its
  top, slides 5 cm along it at 5 cm/s. Reference: a tube of constant section pushes back with a
  constant force; measured: the tool's vertical force's spread (max - min) over its mean, as it
  passes sphere after sphere.
- Sticking: the tube on a plate tilted 10 degrees, below the friction angle (mu 0.3: 16.7 degrees).
  Reference: it holds; measured: how far its middle creeps in 2 s.
- Pile: the 4 m tube dropped into a pile, 5 s (validation/pile_overlap): the deepest overlap of two
  non-neighbouring parts, as a share of the diameter, and the floor's deepest penetration.
- Cost: wall seconds per simulated second of each.

The self-contacts already follow the tube (segments between spheres collide as capsules, exact
closest points); the rigid geoms meet the spheres. Writes contacts.json and contacts.png.
"""

from __future__ import annotations

import argparse
import json
import pathlib
import time

import viscera  # noqa: F401  first: headless GL backend

import mujoco  # noqa: E402
import numpy as np  # noqa: E402
from tqdm import tqdm  # noqa: E402

from validation.common import compile_rod, quiet_warnings  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parents[4]
RADIUS = 0.0125  # m
SPACINGS = (1.0, 0.5, 0.25)  # sphere spacing, in radii
TOOL_RADIUS, PRESS = 0.005, 0.002  # m


def spheres_for(length: float, spacing: float) -> int:
    return int(np.ceil(length / (spacing * RADIUS) - 1e-9)) + 1


def ripple(spacing: float) -> dict:
    """The tool's vertical force along a 5 cm slide over the tube's middle."""
    top = 2 * RADIUS - PRESS + TOOL_RADIUS  # tool axis height: PRESS into the tube's top
    tool = (f'<body name="tool" mocap="true" pos="-0.025 0 {top}"><geom type="capsule" size="{TOOL_RADIUS} 0.05" '
            'euler="90 0 0" contype="1" conaffinity="1"/></body><geom type="plane" size="2 2 .1"/>')
    config = dict(length=1.0, control_points=81, radius=RADIUS, collision_spheres=spheres_for(1.0, spacing),
                  shape="line", start=[-0.5, 0, RADIUS], direction=[1, 0, 0], damping=20, friction=0.0,
                  pinned=[0, -1])
    with quiet_warnings():  # the tool starts pressed in, as meant
        model, data, gut = compile_rod(config, 0.001, worldbody=tool)
        for _ in range(500):  # settle under the pressing tool
            mujoco.mj_step(model, data)
    mocap = model.body("tool").mocapid[0]
    forces, start = [], time.perf_counter()
    steps = 1000  # 1 s at 5 cm/s
    for i in range(steps):
        data.mocap_pos[mocap, 0] = -0.025 + 0.05 * (i + 1) / steps
        mujoco.mj_step(model, data)
        forces.append(gut.body_wrench(data, "tool")[2])  # the tube pushes the tool up
    cost = (time.perf_counter() - start) / (steps * model.opt.timestep)
    f = np.asarray(forces[100:])
    return {"mean_N": float(f.mean()), "ripple": float((f.max() - f.min()) / f.mean()), "wall_s_per_sim_s": cost}


def sticking(spacing: float) -> dict:
    """Creep of the middle of a 0.5 m tube lying across a 10-degree slope (mu 0.3 holds it)."""
    angle = np.radians(10.0)
    plate = f'<geom type="box" size="1 1 0.01" pos="0 0 -0.01" euler="0 {-10.0} 0" friction="0.3"/>'
    down = np.array([np.cos(angle), 0.0, -np.sin(angle)])  # down the slope, in the plate
    config = dict(length=0.5, control_points=41, radius=RADIUS, collision_spheres=spheres_for(0.5, spacing),
                  shape="line", start=[0, -0.25, RADIUS / np.cos(angle)], direction=[0, 1, 0], damping=5)
    model, data, gut = compile_rod(config, 0.001, worldbody=plate)
    for _ in range(500):
        mujoco.mj_step(model, data)
    before = gut.axis_points(data, 3)[1].copy()
    start = time.perf_counter()
    while data.time < 2.5:
        mujoco.mj_step(model, data)
    cost = (time.perf_counter() - start) / 2.0
    return {"creep_m": float(np.dot(gut.axis_points(data, 3)[1] - before, down)), "wall_s_per_sim_s": cost}


def pile(spacing: float, quick: bool) -> dict:
    """The 4 m tube dropped into a pile: deepest overlap (share of the diameter), floor penetration."""
    length = 4.0
    config = dict(length=length, control_points=250, radius=RADIUS, collision_spheres=spheres_for(length, spacing),
                  shape="serpentine", box=[-0.1, -0.1, 0.05, 0.1, 0.1, 0.8])
    model, data, gut = compile_rod(config, 0.002, worldbody='<geom type="plane" size="2 2 .1"/>')
    start = time.perf_counter()
    while data.time < (2.0 if quick else 5.0):
        mujoco.mj_step(model, data)
    cost = (time.perf_counter() - start) / data.time
    count = 2 * (gut.sphere_count - 1) + 1
    x = gut.axis_points(data, count)
    arc = np.linspace(0.0, length, count)
    closest = np.inf
    for i in range(0, count, 64):
        d = np.linalg.norm(x[i:i + 64, None, :] - x[None, :, :], axis=-1)
        far = np.abs(arc[i:i + 64, None] - arc[None, :]) >= np.pi * RADIUS
        closest = min(closest, d[far].min())
    return {"overlap_of_diameter": max(0.0, 2 * RADIUS - closest) / (2 * RADIUS),
            "floor_penetration_of_radius": max(0.0, RADIUS - float(x[:, 2].min())) / RADIUS,
            "recoveries": gut.recovery_count(data), "wall_s_per_sim_s": cost}


def run(quick: bool = False) -> dict:
    out = {"spacings_in_radii": list(SPACINGS), "rows": []}
    for spacing in tqdm(SPACINGS, desc="contact study"):
        out["rows"].append({"spacing": spacing, "ripple": ripple(spacing), "sticking": sticking(spacing),
                            "pile": pile(spacing, quick)})
    return out


def plot(result: dict, path: pathlib.Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    rows = result["rows"]
    s = [r["spacing"] for r in rows]
    fig, axes = plt.subplots(1, 3, figsize=(12, 3.6))
    axes[0].plot(s, [100 * r["ripple"]["ripple"] for r in rows], "o-", label="tool force ripple")
    axes[0].plot(s, [100 * r["pile"]["overlap_of_diameter"] for r in rows], "s-", label="pile: deepest overlap")
    axes[0].set_ylabel("% (of the mean force; of the diameter)")
    axes[1].plot(s, [r["ripple"]["mean_N"] for r in rows], "o-")
    axes[1].set_ylabel("tool force at 2 mm into the tube (N)")  # the penalty is per sphere
    for key, label in (("ripple", "sliding tool"), ("sticking", "slope"), ("pile", "4 m pile")):
        axes[2].plot(s, [r[key]["wall_s_per_sim_s"] for r in rows], "o-", label=label)
    axes[2].set_ylabel("wall s per simulated s")
    for ax in axes:
        ax.set_xlabel("sphere spacing (radii)")
        ax.invert_xaxis()
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    axes[2].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="a 2 s pile")
    parser.add_argument("--out", type=pathlib.Path, default=ROOT / "docs" / "validation")
    args = parser.parse_args()
    result = run(args.quick)
    (args.out / "contacts.json").write_text(json.dumps(result, indent=1) + "\n")
    plot(result, args.out / "contacts.png")
    for r in result["rows"]:
        print(f"spacing {r['spacing']:.2f} r: ripple {100 * r['ripple']['ripple']:.1f} % of "
              f"{r['ripple']['mean_N']:.3f} N, creep {1e3 * r['sticking']['creep_m']:.3f} mm, pile overlap "
              f"{100 * r['pile']['overlap_of_diameter']:.1f} %, floor {100 * r['pile']['floor_penetration_of_radius']:.1f} % r, "
              f"cost {r['ripple']['wall_s_per_sim_s']:.3f} / {r['sticking']['wall_s_per_sim_s']:.3f} / "
              f"{r['pile']['wall_s_per_sim_s']:.3f}")


if __name__ == "__main__":
    main()
