"""The stability map under contact: where each integrator fails in the cavity, and where the
defaults sit. Written to docs/validation/contact_stability.json and contact_stability.png.

    python python/tools/contact_stability.py [--duration 8] [--json docs/validation/contact_stability.json]
        [--png docs/validation/contact_stability.png]

The load is bench_cavity.py's vigorous sweep (every actuator on a sine: both tools sweep the
cavity, push through the piled bowel and press loops on each other and on the walls) on the
shipped abdomen, with the tissue at each corner of the tasks' ranges (viscera.tasks.scene:
light or heavy, soft or stiff, slippery or grippy). For each integrator and corner it finds the
fewest substeps per 2 ms step at which the sweep runs without a single divergence recovery
(trying 1, 2, 3, ... up to --most), and records the substeps the plugin chooses by itself from
the timestep (the default, no `substeps` key). A default at or above the fewest stable count is
safe; the margin is theirs' ratio. The free rod's map (no contact: the largest stable step
against stiffness and resolution) is validate.py's stability_map.
"""

from __future__ import annotations

import argparse
import json
import pathlib

import viscera  # noqa: F401  first: headless GL backend

import mujoco  # noqa: E402
from tqdm import tqdm  # noqa: E402

import bench_cavity  # noqa: E402
from viscera import cli  # noqa: E402
from viscera.tasks import scene  # noqa: E402

INTEGRATORS = ("leapfrog", "symplectic_euler", "rk4", "implicit")
EVALUATIONS = {"leapfrog": 1, "symplectic_euler": 1, "rk4": 4, "implicit": 1}  # force evaluations a substep


def recoveries(config: dict[str, str], duration: float) -> tuple[int, int]:
    """The sweep on the abdomen with the intestine's `config`: its recoveries and divergences."""
    xml = scene.with_intestine_config(scene.scene_file(scene.ABDOMEN).read_text(), config)
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    gut = viscera.intestine(model)
    for ctrl in bench_cavity.sweep_controls(model, duration):
        data.ctrl[:] = ctrl
        mujoco.mj_step(model, data)
    return gut.recovery_count(data), gut.divergence_count(data)


def default_substeps(config: dict[str, str]) -> int:
    xml = scene.with_intestine_config(scene.scene_file(scene.ABDOMEN).read_text(), config)
    return int(viscera.intestine(mujoco.MjModel.from_xml_string(xml)).stability()["substeps"])


def measure(duration: float, most: int, quiet: bool = False) -> dict:
    corners = scene.tissue_corners()
    rows = []
    jobs = [(integrator, corner) for integrator in INTEGRATORS for corner in corners]
    for integrator, corner in tqdm(jobs, desc="integrator x tissue", disable=quiet):
        config = dict(corners[corner], integrator=integrator)
        if integrator == "implicit":
            config["sleep"] = "0"  # the implicit step cannot hold part of the rod still
        chosen = default_substeps(config)
        fewest, trials = None, []
        for substeps in range(1, most + 1):
            recovered, diverged = recoveries(dict(config, substeps=str(substeps)), duration)
            trials.append({"substeps": substeps, "recoveries": recovered, "divergences": diverged})
            if recovered == 0 and diverged == 0:
                fewest = substeps
                break
        default_recovered, default_diverged = recoveries(config, duration)
        rows.append({"integrator": integrator, "tissue": corner, "default_substeps": chosen,
                     "fewest_stable_substeps": fewest, "trials": trials,
                     "default_recoveries": default_recovered, "default_divergences": default_diverged,
                     "evaluations_per_substep": EVALUATIONS[integrator]})
    return {"duration_s": duration, "timestep_s": 0.002, "most_substeps_tried": most, "rows": rows}


def plot(results: dict, path: pathlib.Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    corners = list(dict.fromkeys(r["tissue"] for r in results["rows"]))
    top = max(max(r["default_substeps"], r["fewest_stable_substeps"] or results["most_substeps_tried"] + 1)
              for r in results["rows"])
    fig, axes = plt.subplots(1, len(INTEGRATORS), figsize=(4 * len(INTEGRATORS), 4.4), sharey=True)
    for ax, integrator in zip(axes, INTEGRATORS):
        rows = [r for r in results["rows"] if r["integrator"] == integrator]
        x = range(len(rows))
        fewest = [r["fewest_stable_substeps"] or results["most_substeps_tried"] + 1 for r in rows]
        ax.bar(x, fewest, color="#d9a7a0", label="fewest without a recovery")
        ax.scatter(list(x), [r["default_substeps"] for r in rows], marker="_", s=320, linewidths=3, color="black",
                   label="chosen by the plugin (default)", zorder=3)
        ax.set_ylim(0, top + 1.6)
        ax.set_yticks(range(0, top + 2))
        short = {"slippery": "slip", "grippy": "grip"}
        ax.set_xticks(list(x), ["\n".join(short.get(w, w) for w in c.split("_")) for c in corners], fontsize=7)
        ax.set_title(integrator.replace("_", " "))
        ax.grid(axis="y", alpha=0.3)
    axes[0].set_ylabel("substeps per 2 ms step")
    handles, labels = axes[0].get_legend_handles_labels()
    fig.suptitle("Under contact (the cavity's vigorous sweep, tissue at the ends of the tasks' ranges): "
                 "below the bar an integrator recovers", fontsize=10)
    fig.legend(handles, labels, loc="upper center", bbox_to_anchor=(0.5, 0.93), ncols=2, fontsize=8, frameon=False)
    fig.tight_layout(rect=(0, 0, 1, 0.88))
    fig.savefig(path, dpi=110)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python python/tools/contact_stability.py",
                                     description=__doc__.split("\n")[0])
    parser.add_argument("--duration", type=cli.duration, default=8.0, help="simulated seconds of each sweep (default 8)")
    parser.add_argument("--most", type=cli.positive_int, default=8, help="most substeps tried (default 8)")
    parser.add_argument("--json", type=cli.output_file(".json"), help="write the map to this JSON file")
    parser.add_argument("--png", type=cli.output_file(".png"), help="draw it into this PNG")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    args = parser.parse_args(argv)
    results = measure(args.duration, args.most, args.quiet)
    for r in results["rows"]:
        print(f"{r['integrator']:<17} {r['tissue']:<22} fewest stable {r['fewest_stable_substeps']}, "
              f"default {r['default_substeps']} ({r['default_recoveries']} recoveries)")
    if args.json:
        pathlib.Path(args.json).write_text(json.dumps(results, indent=2) + "\n")
    if args.png:
        plot(results, pathlib.Path(args.png))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
