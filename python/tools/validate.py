"""Every validation case against its analytic reference, at several resolutions, peers alongside,
with charts: the runner over validation/ (one folder per case, see validation/__init__.py).

    python python/tools/validate.py [--quick] [--no-peers] [--case NAME] [--out docs/validation]

Each case builds a MuJoCo model with one intestine (the whole stack: plugin, core, MuJoCo's
step), lets it come to rest under damping (dynamic relaxation) or rings freely, and compares a
measured value with its analytic reference (each case's docstring; formulas in docs/validation.md).
Then the invariants (validation/invariants) and the integrators (validation/integrators). Peers
(validation/peers.py: MuJoCo's 1D flexcomp and cable, PyElastica if installed) run the same cases
at their own largest stable steps, in the same process.

Per case and resolution: the value, the reference, the relative error, the wall seconds per
simulated second, and the error's order of convergence in control points. Writes results.json and
one Pareto chart per case (error against wall time), the stability map, the cost per substep and
the integrators' speed against accuracy (integrators.png) into the output folder.
"""

from __future__ import annotations

import argparse
import json
import pathlib

import viscera  # noqa: F401  first: headless GL backend

import numpy as np  # noqa: E402
from tqdm import tqdm  # noqa: E402

from validation import all_cases  # noqa: E402
from validation.integrators.study import (cost_per_step, energy_bounds, integrator_accuracy, plot_maps,  # noqa: E402
                                          stability_map, stiff_comparison)
from validation.invariants.study import energy_drift_order, length_preservation  # noqa: E402

CASES = all_cases()


def run(quick: bool = False, quiet: bool = False, peers: bool = True, names: list[str] | None = None
        ) -> tuple[dict, dict]:
    """Every case (or those `names`d) at its resolutions (two with `quick`), and the available
    peers on the same cases (their smallest resolution with `quick`). Returns (ours, peers): per
    case, rows of value, reference, relative error and wall s per sim s; peers per case and peer."""
    cases = {name: CASES[name] for name in (names or CASES)}
    jobs = [("viscera", name, n) for name, (_, sizes) in cases.items() for n in (sizes[:2] if quick else sizes)]
    if peers:
        from validation import peers as peer_module
        for peer in peer_module.PEERS:
            if not peer_module.available(peer):
                continue
            for name in cases:
                sizes = peer_module.RESOLUTIONS.get(name, ())
                jobs += [(peer, name, n) for n in (sizes[:1] if quick else sizes)]
    results: dict = {name: [] for name in cases}
    peer_results: dict = {name: {} for name in cases}
    for who, name, n in tqdm(jobs, desc="validation", disable=quiet):
        if who == "viscera":
            row = CASES[name][0](n)
            row["control_points"] = n
        else:
            row = peer_module.run_peer(who, name, n)
            if "unsupported" in row:
                peer_results[name][who] = row
                continue
            peer_results[name].setdefault(who, [])
        scale = 1.0 if row.pop("absolute_error", False) else abs(row["reference"])
        row["relative_error"] = abs(row["value"] - row["reference"]) / scale
        (results[name] if who == "viscera" else peer_results[name][who]).append(row)
    for name, rows in results.items():
        # observed order: slope of log error against log n over the first two resolutions, before
        # the error meets the floor a case's own physics sets (stretch, geometric nonlinearity)
        if len(rows) >= 2:
            a, b = rows[0], rows[1]
            if a["relative_error"] > 0 and b["relative_error"] > 0:
                rows[1]["order_in_control_points"] = float(
                    -np.log(b["relative_error"] / a["relative_error"]) / np.log(b["control_points"] / a["control_points"]))
    return results, peer_results


PEER_STYLE = {"mujoco_flexcomp": "s--", "mujoco_cable": "^--", "pyelastica": "D--"}


def plot(results: dict, peer_results: dict, folder: pathlib.Path) -> list[pathlib.Path]:
    """One Pareto chart per case: relative error against wall s per sim s, ours at each
    resolution and the peers at theirs."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    paths = []
    for name, rows in results.items():
        if not rows:
            continue
        fig, ax = plt.subplots(figsize=(5.2, 3.8))
        x = [r["wall_s_per_sim_s"] for r in rows]
        y = [max(r["relative_error"], 1e-9) for r in rows]
        ax.loglog(x, y, "o-", label="viscera (leapfrog, lumped M), n control points")
        for r, xi, yi in zip(rows, x, y):
            ax.annotate(f"{r['control_points']}", (xi, yi), textcoords="offset points", xytext=(4, 4), fontsize=7)
        unsupported = []
        for peer, peer_rows in peer_results.get(name, {}).items():
            if isinstance(peer_rows, dict):
                unsupported.append(peer)
                continue
            px = [r["wall_s_per_sim_s"] for r in peer_rows]
            py = [max(r["relative_error"], 1e-9) for r in peer_rows]
            ax.loglog(px, py, PEER_STYLE.get(peer, "x--"), label=f"{peer}, segments")
            for r, xi, yi in zip(peer_rows, px, py):
                ax.annotate(f"{r['segments']}", (xi, yi), textcoords="offset points", xytext=(4, -9), fontsize=7)
        ax.set_xlabel("wall seconds per simulated second")
        ax.set_ylabel("relative error" if name != "pile_overlap" else "overlap / diameter")
        title = name.replace("_", " ")
        if unsupported:
            title += "\n(cannot express it: " + ", ".join(unsupported) + ")"
        ax.set_title(title, fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
        fig.tight_layout()
        path = folder / f"pareto_{name}.png"
        fig.savefig(path, dpi=110)
        plt.close(fig)
        paths.append(path)
    return paths


def report(results: dict, peer_results: dict | None = None) -> str:
    lines = [f"{'case':<20}{'model':<17}{'n':>5}{'value':>13}{'reference':>13}{'rel. error':>12}{'wall s/sim s':>14}"
             f"{'order':>7}"]
    for name, rows in results.items():
        for r in rows:
            order = f"{r['order_in_control_points']:.2f}" if "order_in_control_points" in r else ""
            lines.append(f"{name:<20}{'viscera':<17}{r['control_points']:>5}{r['value']:>13.6g}{r['reference']:>13.6g}"
                         f"{r['relative_error']:>12.2e}{r['wall_s_per_sim_s']:>14.4f}{order:>7}")
        for peer, peer_rows in (peer_results or {}).get(name, {}).items():
            if isinstance(peer_rows, dict):
                lines.append(f"{name:<20}{peer:<17}  cannot express it: {peer_rows['unsupported']}")
                continue
            for r in peer_rows:
                lines.append(f"{name:<20}{peer:<17}{r['segments']:>5}{r['value']:>13.6g}{r['reference']:>13.6g}"
                             f"{r['relative_error']:>12.2e}{r['wall_s_per_sim_s']:>14.4f}"
                             f"   (step {r['timestep_s'] * 1e3:.3g} ms)")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python python/tools/validate.py", description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="two resolutions per case, peers at one")
    parser.add_argument("--no-peers", action="store_true", help="our model only")
    parser.add_argument("--out", type=pathlib.Path, default=pathlib.Path("docs") / "validation",
                        help="folder for results.json and the charts (default docs/validation)")
    parser.add_argument("--quiet", action="store_true", help="no progress bars")
    parser.add_argument("--case", action="append", choices=sorted(CASES), metavar="NAME",
                        help="run only this case (repeatable; then no studies, no results.json): "
                             + ", ".join(sorted(CASES)))
    args = parser.parse_args(argv)
    if args.case:
        results, peer_results = run(args.quick, args.quiet, peers=not args.no_peers, names=args.case)
        print(report(results, peer_results))
        return 0
    results, peer_results = run(args.quick, args.quiet, peers=not args.no_peers)
    drift = energy_drift_order(args.quick)
    lengths = length_preservation()
    stability = stability_map(args.quick)
    cost = cost_per_step(args.quick)
    accuracy = integrator_accuracy(args.quick)
    stiff = stiff_comparison(args.quick)
    bounds = energy_bounds(20.0 if args.quick else 100.0)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "results.json").write_text(json.dumps(
        {"cases": results, "peers": peer_results, "energy_drift": drift, "length_preservation": lengths,
         "stability_map": stability, "cost_per_step": cost, "integrator_accuracy": accuracy,
         "stiff_comparison": stiff, "energy_bounds": bounds}, indent=2))
    plot(results, peer_results, args.out)
    plot_maps(stability, cost, accuracy, args.out)
    print(report(results, peer_results))
    print("energy drift over 1 s (RK4, no damping): " + ", ".join(
        f"{r['step_s'] * 1e3:.2g} ms: {r['relative_energy_drift']:.2e}" for r in drift["rows"])
        + f"; order in dt {drift['order_in_dt']:.2f}")
    print("hanging 4 m intestine, relative stretch: " + ", ".join(
        f"{k.replace('_', ' ')}: {v['relative_stretch']:.4f}" for k, v in lengths.items()))
    for integrator, maps in stability.items():
        for key, label in (("against_stretch_stiffness", "stretch_stiffness"), ("against_control_points", "control_points")):
            print(f"{integrator} largest stable substep vs {label}: " + ", ".join(
                f"{r[label]}: {r['largest_step_s'] * 1e3:.3g} ms ({r['failure']})" for r in maps[key]))
    for integrator, table in cost.items():
        print(f"{integrator} cost per substep (us): " + ", ".join(
            f"n={r['control_points']}: {r['seconds_per_substep'] * 1e6:.1f}" for r in table["rows"])
            + f"; log-log slope {table['slope']:.2f}")
    for integrator, rows in accuracy.items():
        print(f"{integrator} error at 0.25 s / amplitude: " + ", ".join(
            f"{r['step_s'] * 1e3:g} ms: " + ("diverged" if r["diverged"] else
                                            f"{r['error_over_amplitude']:.2e} ({r['wall_s_per_sim_s']:.3f} s/s)")
            for r in rows))
    for r in stiff:
        print(f"{r['case']}, {r['integrator']}: " + (f"{r['substeps']} substeps at 2 ms, error "
              f"{r['relative_error']:.2e}, {r['wall_s_per_sim_s']:.3f} wall s/sim s" if r["substeps"]
              else "diverged at every substep count tried"))
    for integrator, row in bounds.items():
        print(f"{integrator} ({row['substeps']} substeps at 2 ms), energy error / swing energy: first half "
              f"{row['first_half']:.3g}, second half {row['second_half']:.3g}")
    print(f"wrote {args.out / 'results.json'} and the charts")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
