"""The pages' tables of measured figures, generated from the results JSON, never copied by hand.

    python docs/tables.py            # rewrite every generated table in docs/*.md and README.md
    python docs/tables.py --check    # exit 1 if a page differs from its JSON (tests/python/test_docs.py)

A generated table sits between `<!-- table: NAME -->` and `<!-- end table -->` in a page, a
single figure in a sentence between `<!-- value: FILE KEY FORMAT -->` and `<!-- end value -->`
(see VALUE below); NAME is a function below, fed by docs/validation/results.json (python python/tools/validate.py),
docs/bench/results.json (python python/tools/bench_fall.py --json), docs/bench/cavity.json
(python python/tools/bench_cavity.py --json; docs/bench/cavity_anatomical.json with --scene anatomical;
docs/bench/cavity_anatomical_trade.json, cited in docs/cavity.md, likewise),
docs/bench/instances.json (python python/tools/bench_instances.py
--json docs/bench/instances.json), docs/pixels/bench.json (python
python/tools/bench_pixels.py --json docs/pixels/bench.json), docs/scale/tasks.json (python
python/tools/bench_scale.py --parts tasks --json docs/scale/tasks.json), docs/tasks/rates.json (python
python/tools/task_rates.py --out docs/tasks/rates.json; docs/tasks/random_stability.json and
docs/tasks/rates_anatomical.json and docs/tasks/rates_anatomical_long.json likewise),
docs/validation/contact_stability.json (python python/tools/contact_stability.py), docs/validation/handling.json
(python python/tools/validation/organ/handling.py), docs/validation/contacts.json
(python python/tools/validation/contacts/study.py), docs/validation/tolerance.json
(python python/tools/tolerance_study.py), docs/rehearsal/band.json (python
python/tools/reference_band.py), docs/learning/*.json (python/tools/learning: dataset_speed.py,
bc.py, rl_grasp_lift.py), the plugin's table of config keys
(plugin/mujoco/keys.h, read through the installed viscera) or the table of tissue parameters (viscera.tissue).
"""

from __future__ import annotations

import json
import pathlib
import re
import sys

DOCS = pathlib.Path(__file__).resolve().parent
MARK = re.compile(r"(<!-- table: (\w+) -->\n)(.*?)(<!-- end table -->)", re.S)
NAMES = {"rk4": "RK4", "leapfrog": "leapfrog", "symplectic_euler": "symplectic Euler", "implicit": "implicit"}


def _json(relative: str) -> dict:
    return json.loads((DOCS / relative).read_text())


def _rows(header: list[str], rows: list[list[str]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    return "\n".join(lines + ["| " + " | ".join(row) + " |" for row in rows]) + "\n"


def _ms(seconds: float) -> str:
    return f"{seconds * 1e3:.3g}"


def stability_map() -> str:
    maps = _json("validation/results.json")["stability_map"]

    def column(integrator, key, label):
        rows = maps[integrator][key]
        if all(r["failure"].startswith("stable at") for r in rows):
            return "stable at 20 ms at every " + ("stiffness" if "stiffness" in label else "resolution")
        return ", ".join(_ms(r["largest_step_s"]) for r in rows) + " ms"
    out = []
    for key, label, what in (("against_stretch_stiffness", "stretch_stiffness", "stretch stiffness {} N/m (250 points)"),
                             ("against_control_points", "control_points", "control points {} (default stiffness)")):
        values = ", ".join(str(r[label]) for r in maps["rk4"][key])
        out.append([what.format(values)] + [column(i, key, label) for i in maps])
    return _rows([""] + [NAMES.get(i, i) for i in maps], out)


def stiff_cases() -> str:
    rows = _json("validation/results.json")["stiff_comparison"]
    cases = list(dict.fromkeys(r["case"] for r in rows))
    integrators = list(dict.fromkeys(r["integrator"] for r in rows))
    out = []
    for case in cases:
        cells = []
        for integrator in integrators:
            r = next(r for r in rows if r["case"] == case and r["integrator"] == integrator)
            cells.append(f"{r['substeps']} substeps: {r['relative_error']:.2e}, {r['wall_s_per_sim_s']:.3f} wall s/sim s"
                         if r["substeps"] else "diverged at every count tried")
        out.append([case] + cells)
    return _rows(["case"] + [NAMES.get(i, i) for i in integrators], out)


def speed_against_accuracy() -> str:
    accuracy = _json("validation/results.json")["integrator_accuracy"]
    integrators = list(accuracy)
    steps = [r["step_s"] for r in accuracy[integrators[0]]]
    out = []
    for k, step in enumerate(steps):
        cells = []
        for integrator in integrators:
            r = accuracy[integrator][k]
            cells.append("diverges" if r["diverged"] else f"{r['error_over_amplitude']:.1e} ({r['wall_s_per_sim_s']:.3f})")
        out.append([f"{step * 1e3:g} ms"] + cells)
    return _rows(["step"] + [NAMES.get(i, i) for i in integrators], out)


def cost_per_substep() -> str:
    cost = _json("validation/results.json")["cost_per_step"]
    first = next(iter(cost.values()))["rows"]
    header = ["control points"] + [str(r["control_points"]) for r in first] + ["log-log slope"]
    out = [[f"{NAMES.get(i, i)} (us)"] + [f"{r['seconds_per_substep'] * 1e6:.0f}" for r in table["rows"]] +
           [f"{table['slope']:.2f}"] for i, table in cost.items()]
    return _rows(header, out)


FALL_LABELS = {"viscera": "viscera, self-collision on", "viscera_noself": "viscera, self-collision off",
               "flexcomp": "MuJoCo flexcomp, selfcollide none", "flexcomp_self": "MuJoCo flexcomp, selfcollide auto"}


def fall() -> str:
    bench = _json("bench/results.json")
    out = [[FALL_LABELS.get(name, name), f"{p['wall_s_per_sim_s_median']:.3g}", f"{p['length_error'] * 100:+.2f} %"]
           for name, p in bench["peers"].items()]
    out.append([f"**viscera with self-collision: {bench['speedup_vs_flexcomp_selfcollide']:.1f}x faster than the "
                f"flexcomp with it, {bench['speedup_vs_flexcomp']:.1f}x than without**", "", ""])
    return _rows(["", "wall s per simulated s", "length error"], out)


CAVITY_LABELS = {"full": "full: 250 points, self-collision, tools, grasping (leapfrog, lumped mass, 3 substeps, "
                         "sleeping)",
                 "sleep off": "the same with `sleep` 0: every point integrated every step",
                 "RK4, consistent mass": "RK4, consistent mass (the previous defaults, 2 substeps)",
                 "consistent mass": "leapfrog, consistent mass (4 substeps)",
                 "spheres 1.5 r": "collision spheres 1.5 r apart (161, not 241)",
                 "rigid only": "rigid only (MuJoCo without the intestine)"}


def cavity_speed() -> str:
    loads = _json("bench/cavity.json")["loads"]
    header = ["variant"]
    for load in loads:
        header += [f"{load}: wall s / sim s", "p50 (ms)", "p99 (ms)", "p99.9 (ms)"]
    variants = list(next(iter(loads.values()))["variants"])
    out = []
    for v in variants:
        row = [CAVITY_LABELS.get(v, v)]
        for load in loads.values():
            r = load["variants"][v]
            row += [f"{r['wall_s_per_sim_s']:.3f}", f"{r['p50_ms']:.3f}", f"{r['p99_ms']:.3f}", f"{r['p999_ms']:.3f}"]
        out.append(row)
    return _rows(header, out)


SLEEP_LOADS = {"gesture": "the clearing gesture (clear_area, seed 0) replayed",
               "rest": "its scene at rest, tools withdrawn",
               "sweep": "the vigorous sweep (both tools through the bowel)"}


def sleep_savings() -> str:
    """Sleeping on against off, from docs/bench/cavity.json (python python/tools/bench_cavity.py
    --json docs/bench/cavity.json)."""
    data = _json("bench/cavity.json")
    rows = []
    for load, entry in data["loads"].items():
        on, off = entry["variants"]["full"], entry["variants"]["sleep off"]
        rows.append([SLEEP_LOADS.get(load, load), f"{off['wall_s_per_sim_s']:.4f}", f"{on['wall_s_per_sim_s']:.4f}",
                     f"**{data['sleep_savings'][load]:.1f}x**", f"{off['p99_ms']:.3f}", f"{on['p99_ms']:.3f}"])
    return _rows(["load (20 s, 2 ms steps)", "sleep off: wall s / sim s", "sleep on", "cheaper (median of runs' ratios)",
                  "p99 step off (ms)", "p99 on (ms)"], rows)


def task_rates() -> str:
    """From docs/tasks/rates.json (python python/tools/task_rates.py --out docs/tasks/rates.json)."""
    data = _json("tasks/rates.json")
    rows = []
    for task, table in data["rates"].items():
        cells = [f"`{task}`"]
        for policy in ("scripted", "random", "nothing"):
            row = table.get(policy)
            cells.append(f"{row['success_rate']:.0%} of {row['episodes']}{_interval(row)}" if row else "-")
        scripted = table.get("scripted")
        steps_per_s = scripted["median_simulated_s"] / data["control_timestep_s"] / scripted["median_wall_s_per_episode"]
        cells.append(f"{scripted['median_wall_s_per_episode']:.1f} s, {scripted['median_simulated_s']:.1f} s "
                     f"simulated, {steps_per_s:.0f}")
        cells.append(", ".join(_recovered(table[p]) for p in ("scripted", "random", "nothing")))
        rows.append(cells)
    seeds = data["seeds"]
    return _rows(["task", f"scripted policy (seeds {seeds['scripted'][0]} to {seeds['scripted'][1]})",
                  f"uniform random actions (seeds {seeds['random'][0]} to {seeds['random'][1]})",
                  f"doing nothing (seeds {seeds['nothing'][0]} to {seeds['nothing'][1]})",
                  "scripted: median wall and simulated time per episode, env steps/s",
                  "episodes with a divergence recovery: scripted, random, nothing"], rows)


def _interval(row: dict) -> str:
    """A rates row's 95 % (Wilson) interval, in brackets after its rate ("" in rates written before
    task_rates.py wrote intervals)."""
    if "interval_95" not in row:
        return ""
    low, high = row["interval_95"]
    return f" ({low:.0%} to {high:.0%})"


HANDOVER_FRACTIONS = ("0.25", "0.5", "0.75")  # task_rates.py's HANDOVER_FRACTIONS, as the JSON's keys


def handover_rates() -> str:
    """The scripted oracles handed a noisy episode part-way, from docs/tasks/rates.json (python
    python/tools/task_rates.py --handover): the success rate and its 95 % interval from the start
    and at each hand-over; a dash where the JSON has no hand-over (written without --handover)."""
    data = _json("tasks/rates.json")
    rows = []
    for task, table in data["rates"].items():
        scripted = table.get("scripted")
        if scripted is None:
            continue
        cells = [f"`{task}`", f"{scripted['success_rate']:.0%} of {scripted['episodes']}{_interval(scripted)}"]
        fractions = scripted.get("handover", {}).get("fractions", {})
        for fraction in HANDOVER_FRACTIONS:
            row = fractions.get(fraction)
            cells.append(f"{row['success_rate']:.0%}{_interval(row)}" if row else "-")
        rows.append(cells)
    seeds = data["seeds"]["scripted"]
    return _rows(["task", f"scripted from the start (seeds {seeds[0]} to {seeds[1]}; 95 % interval)"]
                 + [f"handed over at {float(f):.0%}" for f in HANDOVER_FRACTIONS], rows)


def noisy_rates() -> str:
    """The scripted oracles under action noise throughout, from docs/tasks/rates_noisy.json (python
    python/tools/task_rates.py --noisy): reading back the executed command, and their intended one."""
    data = _json("tasks/rates_noisy.json")
    rows = []
    for task, table in data["rates"].items():
        scripted = table["scripted"]
        readings = scripted["noisy"]["readings"]
        first, last = scripted["seeds"]
        rows.append([f"`{task}`", f"{scripted['success_rate']:.0%} of {scripted['episodes']}, seeds {first} to {last}"
                     f"{_interval(scripted)}"]
                    + [f"{readings[r]['success_rate']:.0%}{_interval(readings[r])}" for r in ("executed", "intended")])
    share = next(iter(data["rates"].values()))["scripted"]["noisy"]["noise_of_range"]
    return _rows(["task", "without noise (95 % interval)",
                  f"{share:.0%} noise, reading the executed command", f"{share:.0%} noise, reading the intended command"],
                 rows)


def anatomical_rates() -> str:
    """The scripted policies on the anatomical abdomen, from docs/tasks/rates_anatomical.json (python
    python/tools/task_rates.py --scene anatomical --policies scripted --out docs/tasks/rates_anatomical.json)."""
    data = _json("tasks/rates_anatomical.json")
    rows = []
    for task, table in data["rates"].items():
        row = table["scripted"]
        steps_per_s = row["median_simulated_s"] / data["control_timestep_s"] / row["median_wall_s_per_episode"]
        seeds = f", seeds {row['seeds'][0]} to {row['seeds'][1]}" if "seeds" in row else ""
        rows.append([f"`{task}`", f"{row['success_rate']:.0%} of {row['episodes']}{seeds}{_interval(row)}",
                     f"{row['median_wall_s_per_episode']:.1f} s, {row['median_simulated_s']:.1f} s simulated, "
                     f"{steps_per_s:.0f}", _recovered(row)])
    per_task = all("seeds" in table["scripted"] for table in data["rates"].values())
    seeds = data["seeds"]["scripted"]
    return _rows(["task", "scripted policy (episodes, seeds; 95 % interval)" if per_task else
                  f"scripted policy (seeds {seeds[0]} to {seeds[1]})",
                  "median wall and simulated time per episode, env steps/s", "episodes with a divergence recovery"],
                 rows)


ANATOMICAL_VARIANTS = {"full": "the anatomical abdomen: 5.06 m tapered small bowel (300 points, 543 spheres) and 1.44 m colon",
                       "sleep off": "the same with `sleep` 0",
                       "spheres 1.5 r": "the small bowel's spheres 1.5 r apart (362, not 543)",
                       "no self-collision": "no self-collision in the small bowel",
                       "rigid only": "rigid only (MuJoCo without the intestines)"}


def anatomical_speed() -> str:
    """From docs/bench/cavity_anatomical.json (python python/tools/bench_cavity.py --scene anatomical
    --json docs/bench/cavity_anatomical.json ...): wall s per simulated s and real-time factor."""
    data = _json("bench/cavity_anatomical.json")
    loads = data["loads"]
    header = ["variant"] + [f"{load}: wall s / sim s (real time)" for load in loads] + ["sweep: p99 step (ms)"]
    out = []
    for v in next(iter(loads.values()))["variants"]:
        row = [ANATOMICAL_VARIANTS.get(v, v)]
        for entry in loads.values():
            cost = entry["variants"][v]["wall_s_per_sim_s"]
            row.append(f"{cost:.3f} ({1.0 / cost:.1f}x)")
        row.append(f"{loads['sweep']['variants'][v]['p99_ms']:.3f}" if "sweep" in loads else "-")
        out.append(row)
    return _rows(header, out)


def _recovered(row: dict) -> str:
    """Episodes of a rates row whose intestine recovered from a diverged step, and their recoveries."""
    if "recoveries" not in row:
        return "-"  # measured before recoveries were counted
    counts = [r for r in row["recoveries"] if r > 0]
    return f"{len(counts)} ({sum(counts)})" if counts else "0"


def random_stability() -> str:
    """From docs/tasks/random_stability.json (python python/tools/task_rates.py --policies random
    --first-seed 3000 --max-steps 300 --out docs/tasks/random_stability.json)."""
    data = _json("tasks/random_stability.json")
    rows = []
    for task, table in data["rates"].items():
        row = table["random"]
        rows.append([f"`{task}`", str(row["episodes"]), str(row["min_control_steps"]),
                     str(sum(1 for r in row["recoveries"] if r > 0)), str(row["recoveries_total"]),
                     str(row["divergences_total"])])
    seeds = data["seeds"]["random"]
    return _rows(["task", f"episodes (seeds {seeds[0]} to {seeds[1]})", "control steps each", "episodes with a recovery",
                  "recoveries", "divergences"], rows)


def contact_stability() -> str:
    """From docs/validation/contact_stability.json (python python/tools/contact_stability.py)."""
    data = _json("validation/contact_stability.json")
    integrators = list(dict.fromkeys(r["integrator"] for r in data["rows"]))
    corners = list(dict.fromkeys(r["tissue"] for r in data["rows"]))
    cell = {(r["integrator"], r["tissue"]): r for r in data["rows"]}
    out = []
    for corner in corners:
        row = [corner.replace("_", ", ")]
        for integrator in integrators:
            r = cell[(integrator, corner)]
            fewest = r["fewest_stable_substeps"]
            row.append(f"{r['default_substeps']} / " + (str(fewest) if fewest else f"> {data['most_substeps_tried']}")
                       + ("" if r["default_recoveries"] == 0 else f" ({r['default_recoveries']} recoveries)"))
        out.append(row)
    return _rows(["tissue (mass, springs, grip)"] + [NAMES.get(i, i) for i in integrators], out)


def task_success() -> str:
    """The README's summary of docs/tasks/rates.json: success rates only."""
    data = _json("tasks/rates.json")
    seeds = data["seeds"]
    rows = [[f"`{task}`"] + [f"{table[p]['success_rate']:.0%}" for p in ("scripted", "random", "nothing")]
            for task, table in data["rates"].items()]
    return _rows(["task", f"scripted policy succeeds (seeds {seeds['scripted'][0]} to {seeds['scripted'][1]}, "
                          "the oracles' failures on 1000 to 1049 were studied)", f"uniform random actions ({seeds['random'][1] - seeds['random'][0] + 1} seeds)",
                  f"doing nothing ({seeds['nothing'][1] - seeds['nothing'][0] + 1} seeds)"], rows)


def reference_band() -> str:
    """From docs/rehearsal/band.json (python python/tools/reference_band.py): each task's scripted
    scores on unseen seeds, median (quartiles); less is better in every column."""
    data = _json("rehearsal/band.json")
    columns = [("time_s", "time (s)", "{:.1f}"), ("path_length_m", "tip path, all tools (m)", "{:.2f}"),
               ("angular_path_deg", "angular path (deg)", "{:.0f}"), ("idle_s", "idle, all tools (s)", "{:.1f}"),
               ("peak_force_n", "peak tool force (N)", "{:.2f}"), ("out_of_view_s", "out of view, all tools (s)", "{:.1f}"),
               ("peak_pinch_n", "peak pinch (N)", "{:.1f}"), ("force_time_product_ns", "largest grasp's force-time (N s)", "{:.0f}"),
               ("safety_cost", "safety cost", "{:.1f}")]
    tasks = list(data["tasks"])
    rows = [["success"] + [f"{data['tasks'][t]['success_rate']:.0%}" for t in tasks]]
    for key, label, form in columns:
        cells = [label]
        for task in tasks:
            f = data["tasks"][task]["figures"][key]
            cells.append(f"{form.format(f['median'])} ({form.format(f['q1'])} to {form.format(f['q3'])})")
        rows.append(cells)
    first, last = data["seeds"]
    return _rows([f"scripted, seeds {first} to {last}: median (quartiles)"] + [f"`{t}`" for t in tasks], rows)


def haptic_protocol() -> str:
    """The socket device's protocol, from its module's docstring (viscera/teleop/protocol.py), the
    one place it is written."""
    from viscera.teleop import protocol
    doc = protocol.__doc__
    return doc[doc.index("Transport:"):].strip() + "\n"


def task_throughput() -> str:
    """From docs/scale/tasks.json (python python/tools/bench_scale.py --parts tasks --json docs/scale/tasks.json)."""
    data = _json("scale/tasks.json")
    policies = list(data["tasks"][0]["steps_per_s"])
    rows = [[f"`{r['task']}`", f"{r['reset_s']:.2f}"] + [f"{r['steps_per_s'][p]:.0f}" for p in policies]
            for r in data["tasks"]]
    return _rows(["task", "reset (s)"] + [f"env steps/s, {p}" for p in policies], rows)


def env_step() -> str:
    """From docs/bench/env_step.json (python python/tools/bench_env_step.py)."""
    data = _json("bench/env_step.json")
    rows = [[f"`{task}`", f"{r['step_over_physics']:.2f}x", f"{r['env_step_ms']:.2f}", f"{r['physics_step_ms']:.2f}",
             f"{r['reset_over_step']:.0f}", f"{r['reset_ms']:.0f}"] for task, r in data["tasks"].items()]
    goals = data["goals"]
    rows.append([f"*goal*", f"{goals['step_over_physics']:.1f}x", "", "", f"{goals['reset_over_step']:.0f}", ""])
    return _rows(["task", "env step / its physics", "env step (ms)", "physics (ms)", "reset, in env steps",
                  "reset (ms)"], rows)


def pixel_speed() -> str:
    """From docs/pixels/bench.json (python python/tools/bench_pixels.py --json docs/pixels/bench.json)."""
    data = _json("pixels/bench.json")
    rows = []
    for r in data["rows"]:
        f = r["frame_ms"]
        rows.append([f"{r['size']} x {r['size']}", f"{r['steps_per_s_off']:.0f}", f"{r['steps_per_s_on']:.0f}",
                     f"{f['whole frame']:.1f}", f"{f['scene update']:.2f}", f"{f['render']:.2f}",
                     f"{f['read-back']:.2f}", f"{f['labels and arrays']:.2f}",
                     f"{r['peer_ms']['laparoscope']:.0f} ({r['speedup_over_peer']:.0f}x)"])
    return _rows(["frame", "env steps/s, pixels off", "env steps/s, pixels on", "frame (ms)", "scene update",
                  "render (2 draws)", "read-back", "labels, arrays", "MuJoCo's renderer at the defaults, RGB only (ms)"],
                 rows)


def tolerance() -> str:
    """From docs/validation/tolerance.json (python python/tools/tolerance_study.py): per tolerance,
    the resolution it chose for each group's cases, their worst error and cost."""
    rows = _json("validation/tolerance.json")["verification"]
    out = []
    for tol in sorted({r["tolerance"] for r in rows}, reverse=True):
        for group, label in (("bending", "with EI: cantilever, tip load, elastica, vibration"),
                             ("springs", "springs alone: catenary, hanging rod"),
                             ("contact", "a 1 m tube resting on a plane (springs, can touch; its rest height)")):
            mine = [r for r in rows if r["tolerance"] == tol and r["group"] == group]
            if not mine:
                continue
            worst = max(mine, key=lambda r: r["error"])
            slowest = max(mine, key=lambda r: r["wall_s_per_sim_s"])

            def spread(key):
                values = sorted({r[key] for r in mine})
                return f"{values[0]} to {values[-1]}" if len(values) > 1 else f"{values[0]}"
            out.append([f"{tol:g}", label, spread("control_points"), spread("samples_per_segment"),
                        spread("collision_spheres"), spread("substeps"),
                        f"{worst['error']:.1e} ({worst['case'].replace('_', ' ')})",
                        f"{slowest['wall_s_per_sim_s']:.3f}"])
    return _rows(["tolerance", "cases (0.5 m beams, a 4 m catenary, 1 m rods)", "control points",
                  "samples per segment", "collision spheres", "substeps per 1 ms",
                  "worst relative error (case)", "wall s per sim s, dearest case"], out)


def instances_cost() -> str:
    """From docs/bench/instances.json (python python/tools/bench_instances.py --json docs/bench/instances.json)."""
    d = _json("bench/instances.json")
    rows = [[name, f"{cost:.4f}"] for name, cost in d["wall_s_per_sim_s"].items()]
    rows.append([f"**two / one: {d['ratio_two_over_one']:.2f}x** (median of {d['runs']} runs' ratios)", ""])
    return _rows(["load (3 s, 2 ms steps)", "wall s per simulated s"], rows)


def contacts() -> str:
    """From docs/validation/contacts.json (python python/tools/validation/contacts/study.py)."""
    rows = []
    for r in _json("validation/contacts.json")["rows"]:
        rows.append([f"{r['spacing']:g} r", f"{100 * r['ripple']['ripple']:.1f} % of {r['ripple']['mean_N']:.2f} N",
                     f"{round(1e3 * r['sticking']['creep_m'], 3) + 0.0:.3f} mm",  # + 0.0: no -0.000
                     f"{100 * r['pile']['overlap_of_diameter']:.1f} % of the diameter",
                     f"{100 * r['pile']['floor_penetration_of_radius']:.1f} % of r",
                     f"{r['ripple']['wall_s_per_sim_s']:.3f}, {r['pile']['wall_s_per_sim_s']:.3f}"])
    return _rows(["sphere spacing", "tool force ripple (of its mean at 2 mm in)", "creep on a 10 degree slope, 2 s",
                  "4 m pile: deepest overlap", "pile: into the floor", "wall s per sim s: sliding tool, pile"], rows)


def config_keys() -> str:
    """From the plugin's table of keys (plugin/mujoco/keys.h), through the installed library."""
    import viscera
    rows = [[f"`{name}`", doc["values"], doc["unit"], doc["default"], doc["meaning"]]
            for name, doc in viscera.attribute_docs().items()]
    return _rows(["key", "values", "unit", "default", "meaning"], rows)


def organ_handling() -> str:
    """Running the bowel against Barrie 2016 (python python/tools/validation/organ/handling.py)."""
    run = _json("validation/handling.json")["running"]
    ours, theirs = run["viscera"], run["barrie_2016"]
    low, high = run["jaw_force_from_handle_n"]
    rows = [
        ["peak grasp force, per grasp", f"{ours['f_max_n']['mean']:.1f} ± {ours['f_max_n']['sd']:.1f} N (at the jaws)",
         f"{theirs['f_max_n']['mean']:.1f} ± {theirs['f_max_n']['sd']:.1f} N at the handle: {low:.1f} to {high:.1f} N "
         "at the jaws for a 30 to 90 % efficient forceps"],
        ["rms grasp force, per grasp", f"{ours['f_rms_n']['mean']:.1f} ± {ours['f_rms_n']['sd']:.1f} N (at the jaws)",
         f"{theirs['f_rms_n']['mean']:.1f} ± {theirs['f_rms_n']['sd']:.1f} N at the handle"],
        ["jaws closing", f"{ours['close_s']['mean']:.2f} ± {ours['close_s']['sd']:.2f} s",
         f"{theirs['close_s']['mean']:.2f} ± {theirs['close_s']['sd']:.2f} s"],
        ["hold", f"{ours['hold_s']['mean']:.2f} ± {ours['hold_s']['sd']:.2f} s",
         f"{theirs['hold_s']['mean']:.2f} ± {theirs['hold_s']['sd']:.2f} s"],
    ]
    return _rows([f"running the bowel ({run['holds']} grasps)", "viscera, scripted", "live pig (Barrie et al. 2016)"],
                 rows)


def tissue_parameters() -> str:
    """From the table of tissue parameters (viscera.tissue), through the installed package."""
    from viscera import tissue

    def number(x: float) -> str:
        return f"{x:g}"
    rows = [[f"`{p.name}`", p.keys, number(p.value), "fixed" if p.drawn is None else " to ".join(map(number, p.drawn)),
             p.unit, p.measured, p.chosen_by] for p in tissue.PARAMETERS]
    return _rows(["parameter", "config keys", "value", "tasks draw", "unit", "measured", "chosen by"], rows)


# A single figure inside a sentence: <!-- value: FILE KEY FORMAT -->TEXT<!-- end value -->, FILE
# a JSON file under docs/, KEY its path (dots; list indices as numbers), FORMAT a Python format
# spec (".1f", ".0%", "d"), or one after "1/" for the reciprocal (a real-time factor from wall
# seconds per simulated second); TEXT is rewritten from the JSON.
VALUE = re.compile(r"(<!-- value: (\S+) (\S+) (\S+) -->)(.*?)(<!-- end value -->)")


def value(relative: str, key: str, spec: str):
    """The figure at `key` (dotted path) of docs/`relative`."""
    node = _json(relative)
    for part in key.split("."):
        node = node[int(part)] if isinstance(node, list) else node[part]
    if spec.startswith("1/"):
        return format(1.0 / node, spec[2:])
    return format(node, spec)


def dataset_speed() -> str:
    rows = _json("learning/dataset_speed.json")["rows"]
    tasks = sorted({r["task"] for r in rows})
    rate = {(r["task"], r["format"], r["pixels"]): r["episodes_per_hour_per_core"] for r in rows}
    frames = {r["task"]: r["mean_frames_per_episode"] for r in rows if not r["pixels"]}
    header = ["task", "frames per episode", "LeRobot", "LeRobot, pixels", "Minari", "Minari, pixels"]
    return _rows(header, [[t, f"{frames[t]:.0f}"] + [f"{rate[(t, f, p)]:.0f}" for f in ("lerobot", "minari")
                                                     for p in (False, True)] for t in tasks])


def _percent(value: float) -> str:
    return f"{100 * value:.0f} %"


def bc_results() -> str:
    record = _json("learning/bc.json")
    first, last = record["eval_seeds"]
    rows = []
    for task in sorted(record["results"]):
        for kind in ("state", "pixels"):
            r = record["results"][task].get(kind)
            if r is None:
                continue
            time = f"{r['median_time_to_success_s']:.1f}" if r["median_time_to_success_s"] is not None else "-"
            rounds = f", DAgger x {r['dagger_rounds']}" if r["dagger_rounds"] else ""
            interval = r.get("success_interval_95")
            success = f"**{_percent(r['success_rate'])}**" + (
                f" ({_percent(interval[0])} to {_percent(interval[1])})" if interval else "")
            noise = r.get("action_noise")
            noisy = f"{_percent(noise['success_rate'])}" if noise else "-"
            rows.append([task, kind, f"chunks of {r['chunk']}{rounds}",
                         f"{r['demonstrations']} of {r['demonstrations_collected']}", f"{r['env_steps']:,}",
                         success, noisy, time, f"{r['median_path_length_m']:.2f}",
                         f"{r['median_peak_force_n']:.1f}", f"{(r['train_cpu_s'] + r['dagger_cpu_s']) / 60:.0f}",
                         f"{r['policy_bytes'] / 1024:.0f}"])
    header = ["task", "observations", "method", "demonstrations cloned", "environment steps",
              f"success, seeds {first}-{last} (95 % interval)", "with 2 % action noise",
              "median time to success (s)", "median path length (m)",
              "median peak tool force (N)", "training and DAgger (CPU min)", "policy file (kB)"]
    return _rows(header, rows)


def haptics_runs() -> str:
    """From docs/haptics/bench.json and bench_busy.json (python python/tools/bench_haptics.py --runs 3 [--busy])."""
    rows = []
    for name in ("bench.json", "bench_busy.json"):
        record = _json(f"haptics/{name}")
        for number, r in enumerate(record["runs"], start=1):
            hold = r["hold"]
            rows.append([record["other_cores"], str(number), f"{r['rate_hz']:.1f}", f"{100 * r['deadline_misses']:.3f} %",
                         f"{r['latency_p50_ms']:.2f} / {r['latency_p99_ms']:.2f} / {r['latency_max_ms']:.2f}",
                         f"{r['passivity_min_j']:.1g}",
                         (f"{100 * hold['depth_force_relative_oscillation']:.3f} % / "
                          f"{100 * hold['tissue_force_relative_oscillation']:.3f} %") if hold.get("contact", True)
                         else "the press found no bowel",
                         f"{r['session']['ticks_behind']} of {r['session']['ticks']:,}",
                         f"{1e3 * r['simulation_behind_max_s']:.0f} ms"])
    rows.append(["*goal*", "", "1000", "at most 0.1 %", "p99 at most 2", "at least -0.001", "at most 5 %", "", ""])
    return _rows(["other cores", "run", "rate (Hz)", "deadline misses", "latency p50 / p99 / max (ms)",
                  "passivity, least energy put in (J)", "held contact: depth / tissue force oscillation",
                  "session ticks behind real time", "simulation behind the device, at most"], rows)


def bc_reevaluations() -> str:
    """The committed policies' successes before and after each change of the tasks (bc.py --reevaluate)."""
    record = _json("learning/bc.json")
    rows = []
    for task in sorted(record["results"]):
        for kind in ("state", "pixels"):
            r = record["results"][task].get(kind)
            changes = (r or {}).get("reevaluations", [])
            for k, change in enumerate(changes):
                # after a change: what the next change found before it, or the entry's results for the last
                before, after = change["before"], changes[k + 1]["before"] if k + 1 < len(changes) else r
                seeds = [before.get("eval_seeds", [2000, 2049]), after.get("eval_seeds", [2000, 2049])]
                rows.append([task, kind, change["why"], change["date"],
                             f"{_percent(before['success_rate'])} ({seeds[0][0]}-{seeds[0][1]})",
                             f"**{_percent(after['success_rate'])}** ({seeds[1][0]}-{seeds[1][1]})",
                             f"{len(set(before['succeeded_seeds']) & set(after['succeeded_seeds']))} of "
                             f"{len(before['succeeded_seeds'])}"])
    return _rows(["task", "observations", "the change", "re-evaluated", "success before (seeds)", "after (seeds)",
                  "seeds that still succeed"], rows)


def bc_variants() -> str:
    runs: dict[str, list[dict]] = {}
    for v in _json("learning/bc_variants.json")["variants"]:
        runs.setdefault((v["run"], v["temporal_ensemble_m"]), []).append(v)
    rows = []
    for (_, m), rounds in sorted(runs.items(), key=lambda item: (item[1][0]["task"], item[0])):
        v = rounds[0]
        first, last = v["eval_seeds"]
        decay = "" if v["final_learning_rate"] == 1e-3 else f", rate to {v['final_learning_rate']:g}"
        seen = "pixels, proprioception" if v["observations"] == "pixels" else "state"
        inputs = f"{seen}, clock" + (", previous command" if v["previous_command"] else "")
        if v.get("extra_inputs"):
            inputs += f"; {v['extra_inputs']}"
        successes = " → ".join(_percent(r["success_rate"]) for r in sorted(rounds, key=lambda r: r["dagger_rounds"]))
        rows.append([v["task"], str(v["demonstrations"]), inputs, str(v["chunk"]), f"{m:g}",
                     "the command" if v["target"] == "action" else "its change", f"{v['updates']:,}{decay}",
                     f"{successes} ({first}-{last})"])
    return _rows(["task", "demonstrations", "inputs", "chunk", "ensembling m", "target", "updates",
                  "success, after each DAgger round (seeds)"], rows)


def rl_curve() -> str:
    record = _json("learning/rl_grasp_lift.json")
    rows = [[f"{c['env_steps']:,}", f"{c['core_hours']:.2f}", _percent(c["success_rate"]), f"{c['mean_return']:.2f}"]
            for c in record["curve"]]
    final = record.get("final")
    if final is not None:
        first, last = record["final_seeds"]
        steps = record["train_env_steps"] + record["start"].get("demonstration_env_steps", 0)  # as the curve counts
        rows.append([f"**{steps:,} (end)**", f"**{record['train_core_hours']:.2f}**",
                     f"**{_percent(final['success_rate'])}** on {first}-{last}", f"{final['mean_return']:.2f}"])
    for name, reference in record.get("references_on_eval_seeds", {}).items():
        label = "the scripted policy" if name == "scripted" else "uniform random actions"
        rows.append([f"*{label}*", "-", _percent(reference["success_rate"]), f"{reference['mean_return']:.2f}"])
    first, last = record["eval_seeds"]
    return _rows(["environment steps", "CPU core-hours", f"success, seeds {first}-{last}", "mean return"], rows)


def one_substep() -> str:
    """From docs/bench/one_substep.json and one_substep_4114abd.json (python python/tools/one_substep.py
    --json ..., the second in an environment holding 4114abd): the anatomical abdomen's substeps,
    sleep after sweeps and recoveries, and the paper's fall against 8 substeps."""
    rows = []
    for name, label in (("one_substep_4114abd.json", "4114abd (the round's start)"), ("one_substep.json", "this build")):
        r = _json(f"bench/{name}")
        bowel = r["substeps"]["anatomical abdomen"]["intestines"][0]
        asleep = " / ".join(f"{100 * s['asleep_each_second'][-1]:.0f}" for s in r["sweeps"])
        rows.append([label, f"{bowel['substeps']} ({bowel['elastic_rad_s']:.0f} rad/s)", asleep,
                     f"{100 * r['median_asleep_after_rest']:.0f} % ({100 * r['least_asleep_after_rest']:.0f} %)",
                     str(r["recoveries"]), f"{1e3 * r['fall']['largest_centroid_distance_m']:.2f}",
                     f"{1e3 * r['fall']['largest_mean_point_distance_m']:.2f}"])
    sweeps = " / ".join(f"{s['sweep_s']:g}" for s in _json("bench/one_substep.json")["sweeps"])
    return _rows(["build", "small bowel: substeps per 1 ms (elastic mode met)",
                  f"small bowel asleep 5 s after sweeps of {sweeps} s (%)", "median (least)",
                  "recoveries, sweeps and rests", "fall: centroid off 8 substeps (mm)", "fall: mean point off (mm)"],
                 rows)


def versus_4114abd() -> str:
    """From docs/bench/versus_4114abd_anatomical.json and versus_4114abd_box.json (python
    python/tools/bench_versus.py OTHER_PYTHON ..., the other environment holding 4114abd)."""
    rows = []
    for name, scene in (("versus_4114abd_anatomical.json", "anatomical"), ("versus_4114abd_box.json", "box")):
        r = _json(f"bench/{name}")
        for load, e in r["loads"].items():
            label = load if load == "fall" else f"{scene} abdomen, {load.split()[1]}"
            rows.append([label, f"{e['this_wall_s_per_sim_s']:.3f}", f"{e['other_wall_s_per_sim_s']:.3f}",
                         f"**{e['ratio_median']:.2f}** ({min(e['ratios']):.2f} to {max(e['ratios']):.2f}, "
                         f"{len(e['ratios'])} pairs)", f"{1.0 / e['ratio_median']:.2f}x"])
    return _rows(["load", "this build: wall s / sim s", "4114abd: wall s / sim s",
                  "this / 4114abd, median (pairs)", "speed-up"], rows)


def render(text: str) -> str:
    text = MARK.sub(lambda m: m.group(1) + globals()[m.group(2)]() + m.group(4), text)
    return VALUE.sub(lambda m: m.group(1) + value(m.group(2), m.group(3), m.group(4)) + m.group(6), text)


def main(argv: list[str]) -> int:
    stale = []
    for page in sorted(DOCS.rglob("*.md")) + [DOCS.parent / "README.md"]:
        text = page.read_text()
        new = render(text)
        if new != text:
            stale.append(page.name)
            if "--check" not in argv:
                page.write_text(new)
    if "--check" in argv and stale:
        print(f"tables differ from their JSON in {', '.join(stale)}: run python docs/tables.py", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
