"""What a `tolerance` buys: the convergence study the plugin's resolution rule is read from, and the
check of that rule through the `tolerance` key itself.

    python python/tools/tolerance_study.py [--quick] [--out docs/validation]

1. Convergence. The rod validation cases (validation/<case>/case.py) at 1 and 2 samples per
   segment over a range of segment counts, substeps left to the plugin. Two groups, as the rule
   has two: rods with a bending rigidity (cantilever, tip load, elastica alpha 1 to 10, vibration
   modes 1 and 2) and rods of the paper's springs alone (catenary, hanging rod). The elastica
   cases run with 10x their material's EA, so the axis barely stretches (P / EA = 1.6e-5 alpha),
   as their inextensible reference assumes; the catenary with stiff springs (10000
   N/m) for the same reason. Per group and samples per segment, the envelope E(N): the largest
   relative error of any case at N segments or more.
2. The table. Writes plugin/core/src/vsc_tolerance_table.h, the envelopes at 1 sample per segment
   (the rule's; see docs/config.md#tolerance) that vsc_resolution.c reads, and
   docs/validation/tolerance.json.
3. Verification (needs the plugin built with that table): every case again, now given only
   `tolerance` (control points, samples, spheres and substeps left to the plugin), at each
   tolerance of TOLERANCES, and a 1 m tube resting on a plane (a rod that can touch something: its
   rest height against r less the penalty law's penetration, relative to r): the resolution chosen, the error against the reference, the wall time
   per simulated second. The table in docs/config.md is generated from it.
"""

from __future__ import annotations

import argparse
import functools
import json
import pathlib
import time

import viscera  # first: headless GL backend

import numpy as np  # noqa: E402
from tqdm import tqdm  # noqa: E402

from validation.cantilever.case import cantilever  # noqa: E402
from validation.catenary.case import catenary  # noqa: E402
from validation.common import LAST_COMPILED, RADIUS, SECOND_MOMENT, TIP_LENGTH, TIP_RIGIDITY, quiet_warnings  # noqa: E402
from validation.hanging_rod.case import hanging_rod  # noqa: E402
from validation.resting_penetration.case import resting_penetration  # noqa: E402
from validation.tip_load.case import ELASTICA, tip_load  # noqa: E402
from validation.vibration.case import vibration  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parents[2]
HEADER = ROOT / "plugin" / "core" / "src" / "vsc_tolerance_table.h"
TOLERANCES = (3e-2, 1e-2, 3e-3, 1e-3)

# the tip-load cases' axis 10x stiffer than their material's: nearly inextensible, as the elastica is
STIFF_AXIS = 10.0 * (TIP_RIGIDITY / SECOND_MOMENT) * np.pi * RADIUS**2 / TIP_LENGTH  # N/m
STIFF_SPRINGS = 10000.0  # N/m: the catenary's stretch springs (0.01 % strain where its tension peaks)


def _tip(alpha: float):
    return functools.partial(tip_load, alpha=alpha, stretch_stiffness=STIFF_AXIS)


# group -> case -> function of (n, **keys) returning the validation row (value, reference, cost)
GROUPS = {
    "bending": {
        "cantilever": cantilever,
        "tip_load": functools.partial(tip_load, alpha=0.03),  # P / EA = 5e-6: its own axis
        **{f"elastica_alpha_{alpha:g}": _tip(alpha) for alpha in ELASTICA},
        "vibration_mode_1": functools.partial(vibration, mode=1),
        "vibration_mode_2": functools.partial(vibration, mode=2),
    },
    "springs": {
        "catenary": functools.partial(catenary, stretch_stiffness=STIFF_SPRINGS),
        "hanging_rod": hanging_rod,
    },
}
# verified through the key only (not in the envelopes: its reference is the penalty law's own): a rod
# that can touch something, so the tolerance resolves its folds and spaces its spheres
CONTACT = {"contact": {"resting_penetration": resting_penetration}}
SEGMENTS = {"bending": (3, 4, 6, 8, 12, 16, 24, 32, 48, 64, 96), "springs": (4, 6, 8, 12, 16, 24, 32, 48, 64, 96)}


def relative_error(row: dict) -> float:
    return abs(row["value"] / row["reference"] - 1.0)


def envelope(errors: dict[str, dict[int, float]], segments) -> list[list[float]]:
    """E(N) = the largest error of any case at N segments or more: a non-increasing bound."""
    worst = [max(case[n] for case in errors.values()) for n in segments]
    bound = np.maximum.accumulate(worst[::-1])[::-1]
    return [[int(n), float(e)] for n, e in zip(segments, bound)]


def convergence(quick: bool) -> dict:
    out: dict = {}
    jobs = [(group, case, samples, n) for group, cases in GROUPS.items() for case in cases
            for samples in (1, 2) for n in SEGMENTS[group][: (5 if quick else None)]]
    with quiet_warnings():
        for group, case, samples, n in tqdm(jobs, desc="convergence"):
            row = GROUPS[group][case](n + 1, substeps=None, samples_per_segment=samples)
            out.setdefault(group, {}).setdefault(str(samples), {}).setdefault(case, {})[n] = relative_error(row)
    return out


def write_header(envelopes: dict) -> None:
    lines = ["// Generated by python/tools/tolerance_study.py from the validation cases' convergence",
             "// (docs/validation/tolerance.json): do not edit. Per group of rods, the envelope E(N) of",
             "// the relative error against segment count N at 1 sample per segment: at N segments",
             "// over the rod's shortest shape length or more, no validation case of the group erred",
             "// more than E(N). Read by vsc_resolution.c only.",
             "#ifndef VISCERA_TOLERANCE_TABLE_H", "#define VISCERA_TOLERANCE_TABLE_H", ""]
    for group, rows in envelopes.items():
        lines.append(f"// {group}: {{segments, relative error}}, segments increasing")
        lines.append(f"static const double vsc_tolerance_envelope_{group}[][2] = {{")
        lines += [f"    {{{n}, {e:.3e}}}," for n, e in rows]
        lines.append("};")
        lines.append("")
    lines.append("#endif  // VISCERA_TOLERANCE_TABLE_H")
    HEADER.write_text("\n".join(lines) + "\n")


def resolution(gut) -> dict:
    """What the plugin chose for an intestine: counts, and substeps at its model's timestep."""
    return {"control_points": gut.control_count, "samples_per_segment": gut.samples_per_segment,
            "collision_spheres": gut.sphere_count, "substeps": gut.stability()["substeps"]}


def verification(quick: bool) -> list[dict]:
    rows = []
    groups = {**GROUPS, **CONTACT}
    jobs = [(tolerance, group, case) for tolerance in (TOLERANCES[:2] if quick else TOLERANCES)
            for group, cases in groups.items() for case in cases]
    with quiet_warnings():
        for tolerance, group, case in tqdm(jobs, desc="verification"):
            start = time.perf_counter()
            row = groups[group][case](2, control_points=None, substeps=None, integrator=None, tolerance=tolerance)
            # the tube's rest height (r less its penetration) relative to r: the penetration alone, some
            # micrometres, is no scale a tolerance is about
            error = abs(row["value"] - row["reference"]) / RADIUS if group == "contact" else relative_error(row)
            rows.append({"tolerance": tolerance, "group": group, "case": case, "error": error,
                         "wall_s_per_sim_s": row["wall_s_per_sim_s"], "run_s": time.perf_counter() - start,
                         **resolution(LAST_COMPILED["intestine"])})
    return rows


def plot(result: dict, path: pathlib.Path) -> None:
    """Error against segments, per case, at 1 and 2 samples per segment, with the envelope."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), sharey=True)
    for ax, (group, title) in zip(axes, (("bending", "rods with a bending rigidity"),
                                         ("springs", "the paper's springs alone"))):
        for samples, style in (("1", "-"), ("2", ":")):
            for i, (case, errors) in enumerate(result["convergence"][group][samples].items()):
                n = [int(k) for k in errors]
                ax.loglog(n, [max(v, 1e-9) for v in errors.values()], style, color=f"C{i}", lw=1,
                          label=case.replace("_", " ") if samples == "1" else None)
        env = np.array(result["envelopes"][group])
        ax.loglog(env[:, 0], env[:, 1], "k-", lw=2.5, label="envelope (1 sample)")
        ax.set_title(f"{title}: 1 sample per segment (solid), 2 (dotted)", fontsize=9)
        ax.set_xlabel("segments over the shape length")
        ax.set_ylim(1e-6, 1)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    axes[0].set_ylabel("relative error against the analytic reference")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer resolutions and tolerances")
    parser.add_argument("--out", type=pathlib.Path, default=ROOT / "docs" / "validation")
    parser.add_argument("--verify-only", action="store_true",
                        help="keep the committed convergence and table; rerun the verification")
    args = parser.parse_args()
    path = args.out / "tolerance.json"
    if args.verify_only:
        result = json.loads(path.read_text())
    else:
        study = convergence(args.quick)
        result = {"convergence": study,
                  "envelopes": {group: envelope(study[group]["1"], SEGMENTS[group][: (5 if args.quick else None)])
                                for group in GROUPS}}
        write_header(result["envelopes"])
        print(f"wrote {HEADER.relative_to(ROOT)}: rebuild the plugin, then run with --verify-only")
    result["verification"] = verification(args.quick) if args.verify_only else []
    path.write_text(json.dumps(result, indent=1) + "\n")
    plot(result, args.out / "tolerance.png")
    print(f"wrote {path} and tolerance.png")


if __name__ == "__main__":
    main()
