"""Force against time, with the tissue thresholds drawn: docs/rehearsal/force.png.

    python python/tools/force_figure.py [--out docs/rehearsal/force.png] [--seed 1000]

Two scripted episodes on an unseen seed (grasp_lift and retract_reach), traced as the score
traces them (viscera.assess): each tool's force on the tissue against the traction limit, and
the grasper's pinch against the grip that prevents slip and the pinch that perforates.
"""

from __future__ import annotations

import argparse

import numpy as np

from viscera import assess, cli, recording


def trace(task: str, seed: int) -> assess.Trace:
    tracer = []

    def on_step(env, time_step) -> None:
        if not tracer:
            tracer.append(assess.Tracer(env))
        tracer[0].sample(env)

    recording.record(task, seed, "scripted", on_step=on_step)
    return tracer[0].trace


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python python/tools/force_figure.py", description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=cli.output_file(".png"), default="docs/rehearsal/force.png", help="the figure")
    parser.add_argument("--seed", type=cli.natural_int, default=1000, help="the episodes' seed (default 1000)")
    args = parser.parse_args(argv)
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    tasks = ("grasp_lift", "retract_reach")
    figure, axes = plt.subplots(2, len(tasks), figsize=(11, 6), sharex="col", constrained_layout=True)
    for column, task in enumerate(tasks):
        traced = trace(task, args.seed)
        a = traced.arrays()
        time = a["time"]
        top, bottom = axes[0, column], axes[1, column]
        for i, tool in enumerate(traced.tools):
            top.plot(time, np.linalg.norm(a["force"][:, i], axis=1), label=f"{tool}")
        top.axhline(assess.TRACTION_LIMIT_N, color="C3", linestyle="--",
                    label=f"traction limit {assess.TRACTION_LIMIT_N:g} N (Gong 2023)")
        top.set_title(f"{task}, seed {args.seed}: the tissue's force on each tool")
        top.set_ylabel("force (N)")
        top.legend(fontsize=8, loc="upper left")
        for i, tool in enumerate(traced.tools):
            if np.any(a["pinch"][:, i] > 0):
                bottom.plot(time, a["pinch"][:, i], label=f"{tool} pinch")
        bottom.axhline(assess.PERFORATION_PINCH_N, color="C3", linestyle="--",
                       label=f"perforation {assess.PERFORATION_PINCH_N:g} N (Heijnsdijk 2003)")
        bottom.axhline(assess.NOVICE_PINCH_N, color="C1", linestyle=":", label=f"novices' pinch {assess.NOVICE_PINCH_N:g} N")
        bottom.axhline(assess.SLIP_PREVENTING_PINCH_N, color="C2", linestyle="--",
                       label=f"prevents slip {assess.SLIP_PREVENTING_PINCH_N:g} N (de Visser)")
        bottom.set_ylim(0, assess.PERFORATION_PINCH_N * 1.2)
        bottom.set_xlabel("simulated time (s)")
        bottom.set_ylabel("grasp pinch (N)")
        bottom.legend(fontsize=8, loc="upper left")
    figure.savefig(args.out, dpi=110)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
