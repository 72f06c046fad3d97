"""A trainee's attempts on one page: `python -m viscera report FILE [FILE ...] --out report.html`.

    summary = write(["monday.npz", "tuesday.npz"], "report.html")   # needs matplotlib: pip install ".[report]"

Every recording is checked (viscera.recording.load: its structure and ranges) before any is
replayed; then each is replayed bit for bit with viscera.assess's tracer. The page, one HTML file
that opens offline (its charts are inline SVG, its style inline), holds per task:
- each attempt's score against the reference band (the scripted policies on 50 unseen seeds,
  python/tools/reference_band.py; the package's copy, assets/scenes/reference_band.json): a
  successful attempt's figure in the band's best quartile is green, one worse than its third
  quartile amber;
- with several attempts of a task, each figure against the attempt number, the band's best
  quartile and median drawn across: the learning curve (attempts in the order given);
- per attempt, the tissue's force on each tool and each grasper's pinch against time, with
  the limits drawn (viscera.assess: traction 4.62 N, slip-preventing pinch 3 N, perforation
  10.3 N), and the tools' working points seen from above.
"""

from __future__ import annotations

import dataclasses
import datetime
import html
import io
import json
import pathlib

import numpy as np

from viscera import assess, recording

TOOL_COLOURS = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd")
GOOD, POOR = "#d8f0d8", "#fbe3c2"   # cell colours: in the best quartile, worse than the third quartile


class ReportError(RuntimeError):
    """A recording that cannot be read or replayed, or matplotlib missing: one line."""


@dataclasses.dataclass
class Attempt:
    path: str
    recording: recording.Recording
    score: dict
    trace: dict          # viscera.assess.Trace.arrays()
    tools: tuple[str, ...]
    graspers: tuple[str, ...]
    bit_identical: bool


def check_matplotlib() -> None:
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        raise ReportError('report needs matplotlib, which draws its charts: pip install "viscera[report]" '
                          '(from a source tree: pip install ".[report]")') from None


def reference_band() -> dict:
    """The reference band by task (the package's copy of docs/rehearsal/band.json's bands)."""
    from viscera.tasks.scene import scene_file
    return json.loads(scene_file("reference_band.json").read_text())


def replayed(path: str, made: recording.Recording) -> Attempt:
    tracer = []

    def on_step(env, time_step) -> None:
        if not tracer:
            tracer.append(assess.Tracer(env))
        tracer[0].sample(env)

    try:
        result = recording.replay(made, on_step=on_step)
    except recording.RecordingError as error:
        raise ReportError(f"{path}: {error}") from None
    trace = tracer[0].trace
    return Attempt(path, made, assess.score(trace), trace.arrays(), trace.tools, trace.graspers, result.matches(made))


def write(paths: list[str], out: str, progress: bool = False) -> dict:
    """Check every recording, replay each, and write the page to `out`; returns a summary."""
    check_matplotlib()
    loaded = []
    for path in paths:
        try:
            loaded.append((path, recording.load(path)))
        except recording.RecordingError as error:
            raise ReportError(str(error)) from None
    band = reference_band()
    iterator = loaded
    if progress:
        from tqdm import tqdm
        iterator = tqdm(loaded, desc="replaying", unit="attempt")
    attempts = [replayed(path, made) for path, made in iterator]
    page = render(attempts, band)
    pathlib.Path(out).write_text(page, encoding="utf-8")
    return {"attempts": len(attempts), "tasks": sorted({a.recording.task for a in attempts}), "out": out,
            "bytes": len(page.encode("utf-8")), "not_bit_identical": [a.path for a in attempts if not a.bit_identical]}


# -- the page

def render(attempts: list[Attempt], band: dict) -> str:
    by_task: dict[str, list[tuple[int, Attempt]]] = {}
    for number, attempt in enumerate(attempts, start=1):
        by_task.setdefault(attempt.recording.task, []).append((number, attempt))
    sections = [task_section(task, rows, band["tasks"].get(task)) for task, rows in by_task.items()]
    made = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>viscera report: {len(attempts)} attempts</title>
<style>
body {{ font-family: sans-serif; margin: 1.5em auto; max-width: 1200px; color: #222; }}
table {{ border-collapse: collapse; margin: 0.5em 0 1.5em; font-size: 0.9em; }}
th, td {{ border: 1px solid #ccc; padding: 0.25em 0.5em; text-align: right; }}
th {{ background: #f2f2f2; }} td.left, th.left {{ text-align: left; }}
tr.band td {{ background: #f7f7f7; font-style: italic; }}
.charts {{ display: flex; flex-wrap: wrap; gap: 0.5em; }} .charts svg {{ max-width: 100%; height: auto; }}
.note {{ color: #555; font-size: 0.85em; }}
</style></head><body>
<h1>viscera report</h1>
<p class="note">{len(attempts)} attempt{"s" * (len(attempts) != 1)}, replayed bit for bit and scored
({made}). Figures are read against the reference band: the scripted policies on
{_band_seeds(band)}; <span style="background:{GOOD}">green</span>: in its best quartile,
<span style="background:{POOR}">amber</span>: worse than its third quartile (a failed attempt's figures are
left uncoloured: the band is of episodes played to the end). Less is better for every figure.</p>
{"".join(sections)}
</body></html>
"""


def _band_seeds(band: dict) -> str:
    first, last = band["seeds"]
    return f"{last - first + 1} unseen seeds ({first} to {last})"


def task_section(task: str, rows: list[tuple[int, Attempt]], task_band: dict | None) -> str:
    names = [name for name, _, _ in assess.BAND_FIGURES]
    units = {name: unit for name, _, unit in assess.BAND_FIGURES}
    header = "".join(f"<th>{html.escape(_label(name))}{f' ({units[name]})' if units[name] else ''}</th>"
                     for name in names)
    body = []
    if task_band:
        for quartile, label in (("q1", "band: best quartile up to"), ("median", "band: median"),
                                ("q3", "band: third quartile")):
            cells = "".join(f"<td>{task_band['figures'][name][quartile]:.2f}</td>" for name in names)
            body.append(f'<tr class="band"><td class="left" colspan="4">{label}</td>{cells}</tr>')
    for number, attempt in rows:
        made = attempt.recording
        cells = []
        for name, read, _ in assess.BAND_FIGURES:
            value = float(read(attempt.score))
            colour = ""
            if task_band and attempt.score["success"]:  # a failed attempt's figures are not the band's kind
                figure = task_band["figures"][name]
                colour = GOOD if value <= figure["q1"] else POOR if value > figure["q3"] else ""
            cells.append(f'<td style="background:{colour}">{value:.2f}</td>' if colour else f"<td>{value:.2f}</td>")
        verdict = "yes" if attempt.score["success"] else "no"
        body.append(f'<tr><td>{number}</td><td class="left">{html.escape(pathlib.Path(attempt.path).name)}</td>'
                    f'<td class="left">{html.escape(made.policy)}, seed {made.seed}</td><td>{verdict}</td>'
                    f"{''.join(cells)}</tr>")
    success = f"{task_band['success_rate']:.0%} of the band's episodes succeed" if task_band else "no band"
    parts = [f"<h2>{html.escape(task)}</h2>",
             f'<p class="note">{len(rows)} attempt{"s" * (len(rows) != 1)}; {success}.</p>',
             f'<table><tr><th>#</th><th class="left">recording</th><th class="left">who</th><th>success</th>{header}'
             f"</tr>{''.join(body)}</table>"]
    if len(rows) > 1:
        parts.append("<h3>Learning curve</h3>")
        parts.append(f'<div class="charts">{learning_curve(rows, task_band)}</div>')
    for number, attempt in rows:
        parts.append(f"<h3>Attempt {number}: {html.escape(pathlib.Path(attempt.path).name)}</h3>")
        parts.append(f'<div class="charts">{attempt_charts(attempt)}</div>')
    return "\n".join(parts)


def _label(name: str) -> str:
    for suffix in ("_s", "_m", "_deg", "_n", "_ns"):
        if name.endswith(suffix):
            name = name[:-len(suffix)]
    return name.replace("_", " ")


# -- charts (matplotlib, inline SVG)

def _svg(figure) -> str:
    import matplotlib.pyplot as plt
    buffer = io.StringIO()
    figure.savefig(buffer, format="svg", bbox_inches="tight")
    plt.close(figure)
    text = buffer.getvalue()
    return text[text.index("<svg"):]


def _pyplot():
    import matplotlib
    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt
    plt.rcParams["svg.fonttype"] = "none"  # text as text: smaller, and the page's font
    return plt


def learning_curve(rows: list[tuple[int, Attempt]], task_band: dict | None) -> str:
    plt = _pyplot()
    figures = assess.BAND_FIGURES
    columns = 3
    figure, axes = plt.subplots((len(figures) + columns - 1) // columns, columns, figsize=(11, 7.5), squeeze=False)
    numbers = [number for number, _ in rows]
    for axis, (name, read, unit) in zip(axes.ravel(), figures):
        values = [float(read(attempt.score)) for _, attempt in rows]
        colours = ["#2ca02c" if attempt.score["success"] else "#d62728" for _, attempt in rows]
        axis.plot(numbers, values, color="#555", linewidth=1)
        axis.scatter(numbers, values, c=colours, zorder=3, s=18)
        if task_band:
            band = task_band["figures"][name]
            axis.axhline(band["q1"], color="#2ca02c", linestyle="--", linewidth=1, label="band: best quartile")
            axis.axhline(band["median"], color="#999", linestyle=":", linewidth=1, label="band: median")
        axis.set_title(f"{_label(name)}" + (f" ({unit})" if unit else ""), fontsize=9)
        axis.set_xticks(numbers)
        axis.tick_params(labelsize=8)
    for axis in axes.ravel()[len(figures):]:
        axis.set_visible(False)
    axes[-1][0].set_xlabel("attempt (green: succeeded)", fontsize=8)
    if task_band:
        axes[0][0].legend(fontsize=7, loc="best")
    figure.tight_layout()
    return _svg(figure)


def attempt_charts(attempt: Attempt) -> str:
    plt = _pyplot()
    a = attempt.trace
    time = a["time"]
    figure, (forces, pinches, paths) = plt.subplots(1, 3, figsize=(13, 3.3))
    for i, tool in enumerate(attempt.tools):
        colour = TOOL_COLOURS[i % len(TOOL_COLOURS)]
        forces.plot(time, np.linalg.norm(a["force"][:, i], axis=1), color=colour, linewidth=1, label=tool)
        if tool in attempt.graspers:
            pinches.plot(time, a["pinch"][:, i], color=colour, linewidth=1, label=tool)
        paths.plot(100 * a["tip"][:, i, 0], 100 * a["tip"][:, i, 1], color=colour, linewidth=1, label=tool)
        paths.scatter(100 * a["tip"][-1:, i, 0], 100 * a["tip"][-1:, i, 1], color=colour, s=12)
    forces.axhline(assess.TRACTION_LIMIT_N, color="#d62728", linestyle="--", linewidth=1,
                   label=f"traction limit {assess.TRACTION_LIMIT_N:g} N")
    forces.set_title("tissue force on each tool (N)", fontsize=9)
    pinches.axhline(assess.SLIP_PREVENTING_PINCH_N, color="#2ca02c", linestyle=":", linewidth=1,
                    label=f"prevents slip {assess.SLIP_PREVENTING_PINCH_N:g} N")
    pinches.axhline(assess.PERFORATION_PINCH_N, color="#d62728", linestyle="--", linewidth=1,
                    label=f"perforation {assess.PERFORATION_PINCH_N:g} N")
    pinches.set_ylim(0, assess.PERFORATION_PINCH_N * 1.2)
    pinches.set_title("pinch while holding (N)", fontsize=9)
    for axis in (forces, pinches):
        axis.set_xlabel("time (s)", fontsize=8)
        axis.legend(fontsize=7, loc="upper left")
    paths.set_title("working points from above (cm; dot: the end)", fontsize=9)
    paths.set_aspect("equal", adjustable="datalim")
    paths.legend(fontsize=7, loc="best")
    for axis in (forces, pinches, paths):
        axis.tick_params(labelsize=8)
    figure.tight_layout()
    return _svg(figure)
