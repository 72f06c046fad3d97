"""Command line:

    python -m viscera run SCENE.xml [--duration 5] [--png out.png] [--viewer meshcat]
    python -m viscera view SCENE.xml    # MuJoCo's interactive viewer, the intestine drawn
    python -m viscera teleop TASK [--seed S] [--device keyboard] [--record FILE]   # a person at the tools
    python -m viscera play TASK [--seed S] [--policy scripted]     # a whole episode: did it succeed? (exit 0 or 1)
    python -m viscera play TASK --policy FILE.npz                  # ... played by a policy file (viscera.policy_file)
    python -m viscera play TASK --scene anatomical                 # ... in the anatomical abdomen (teleop, record too)
    python -m viscera record TASK --seed S --policy scripted --out FILE             # an episode without a person
    python -m viscera replay FILE [--json OUT] [--viewer meshcat] [--trajectory OUT.json]
    python -m viscera dataset TASK --format lerobot|minari --out PATH [--policy scripted|FILE.npz] [--seeds A:B]
        [--episodes N] [--pixels] [--workers K]          # demonstrations as a LeRobot or Minari dataset
"""

from __future__ import annotations

import argparse
import os
import socket
import sys
import time
from collections.abc import Callable

import viscera  # first: it picks a headless GL backend before mujoco loads

import mujoco  # noqa: E402
import numpy as np  # noqa: E402
from tqdm import tqdm  # noqa: E402

from viscera import checks, cli  # noqa: E402
from viscera.cli import UserError  # noqa: E402

PROG = "python -m viscera"


def camera_id(model: mujoco.MjModel, camera: str | None, scene: str) -> int | None:
    """The id of the scene's camera named (or numbered) `camera`; None stays None (the default view)."""
    if camera is None:
        return None
    try:
        return checks.camera_id(model, camera)
    except ValueError as error:
        raise UserError(f"--camera {camera!r}: {error} ({scene})", status=2) from None


def check_host(host: str) -> None:
    """That the viewer can serve on `host` (an address of this machine): tried now, since the server's
    own failure comes back as its traceback."""
    try:
        family, kind, _, _, address = socket.getaddrinfo(host, 0, type=socket.SOCK_STREAM)[0]
        with socket.socket(family, kind) as probe:
            probe.bind(address)
    except OSError as error:  # gaierror included: no such host name
        raise UserError(f"--host {host!r}: cannot serve on it ({error.strerror or error})", status=2) from error


def _renderer(model: mujoco.MjModel) -> mujoco.Renderer:
    return mujoco.Renderer(model, min(600, int(model.vis.global_.offheight)), min(800, int(model.vis.global_.offwidth)),
                           max_geom=20000)


def _render_png(renderer: mujoco.Renderer, model: mujoco.MjModel, data: mujoco.MjData, path: str,
                camera: int | None) -> None:
    renderer.update_scene(data, camera=camera if camera is not None else (0 if model.ncam > 0 else -1))
    cli.save_png(path, renderer.render())


def run(scene: str, duration: float, png: str | None = None, camera: str | None = None, quiet: bool = False,
        viewer: str | None = None, record: str | None = None, record_fps: float = 10.0, host: str = "127.0.0.1",
        hold: bool = False, report: Callable[[dict], None] | None = None) -> dict:
    """Simulate `scene` for `duration` s with a progress bar; return the summary figures.

    Everything the user gave is checked before the first step (the scene loads, the camera
    exists, the duration spans a step): a mistake raises cli.UserError, not a late traceback.
    With `viewer="meshcat"` the run is shown live (paced to real time, 30 frames per simulated
    second) at a loopback URL, framed by `camera`; `record` writes a self-contained HTML
    recording at `record_fps`. `report` gets the summary while the viewer is still up; `hold`
    then keeps serving the final state until Ctrl-C.
    """
    if hold and viewer != "meshcat":
        raise UserError("--hold needs --viewer meshcat", status=2)
    model = cli.load_model(scene)
    camera_index = camera_id(model, camera, scene)
    steps = int(round(duration / model.opt.timestep))
    if steps < 1:
        raise UserError(f"--duration {duration:g}: shorter than the scene's timestep ({model.opt.timestep:g} s)",
                        status=2)
    if record and record_fps > 1.0 / model.opt.timestep:
        raise UserError(f"--record-fps {record_fps:g}: more than the scene's {1.0 / model.opt.timestep:g} steps "
                        f"per simulated second (timestep {model.opt.timestep:g} s)", status=2)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    renderer = view = None
    try:
        renderer = _renderer(model) if png else None  # a missing GL shows now, not after the run
        if viewer == "meshcat" or record:
            from viscera.viewer import MeshcatViewer
            if viewer == "meshcat":
                check_host(host)
                view = MeshcatViewer(model, host=host, camera=camera_index)
                print(f"meshcat viewer: {view.url}", flush=True)
            else:  # a recording alone needs no server
                view = MeshcatViewer(model, camera=camera_index, serve=False)
        record_every = max(1, int(round(1.0 / (record_fps * model.opt.timestep))))
        wall = _simulate(model, data, steps, view, live=viewer == "meshcat", record_every=record_every if record else 0,
                         quiet=quiet, desc=os.path.basename(scene))
        summary = {"scene": scene, "simulated_s": data.time, "wall_s": wall,
                   "real_time_factor": data.time / wall if wall > 0 else float("inf"), "intestines": []}
        for gut in viscera.intestines(model):
            axis = gut.axis_points(data, 4000)
            summary["intestines"].append({
                "name": gut.name, "rest_length_m": gut.rest_length, "final_length_m": gut.length(data),
                "lowest_point_m": float(axis[:, 2].min()), "max_speed_m_s": float(np.abs(gut.velocities(data)).max()),
                "divergences": gut.divergence_count(data)})
        if png:
            _render_png(renderer, model, data, png, camera_index)
            summary["png"] = png
        if record:
            # played at the rate it was recorded at: whole steps apart, not always `record_fps`
            summary["recording_bytes"] = view.save(record, fps=1.0 / (record_every * model.opt.timestep))
            summary["recording"] = record
            summary["recording_frames"] = len(view.frames)
        if report is not None:
            report(summary)
        if hold:
            try:
                if not view.serving:
                    raise RuntimeError("the meshcat server stopped during the run: nothing to serve")
                print(f"serving the final state at {view.url}; Ctrl-C to stop", flush=True)
                view.hold()
            except KeyboardInterrupt:  # the way a hold ends: not an interrupted run
                pass
            except RuntimeError as error:  # the server died: the page is gone, say so
                raise UserError(f"--hold: {error}") from error
    finally:
        if view is not None:
            view.close()
        if renderer is not None:
            renderer.close()
    return summary


def _simulate(model: mujoco.MjModel, data: mujoco.MjData, steps: int, view, live: bool, record_every: int,
              quiet: bool, desc: str) -> float:
    """Step `steps` times, showing on `view` and recording every `record_every` steps (0: not at all; the
    first and the final states always); return the wall time spent stepping (s)."""
    display_every = max(1, int(round(1.0 / (30.0 * model.opt.timestep))))
    chunk = display_every if live else max(1, steps // 200)
    wall_start = time.perf_counter()
    stepping = 0.0
    if view is not None:
        view.update(data)
    if record_every:
        view.record(data)
    with tqdm(total=steps, unit="step", disable=quiet, desc=desc) as bar:
        done = 0
        while done < steps:
            count = min(chunk, steps - done)
            tick = time.perf_counter()
            for _ in range(count):
                mujoco.mj_step(model, data)
                done += 1
                if record_every and (done % record_every == 0 or done == steps):
                    view.record(data)
            stepping += time.perf_counter() - tick
            bar.update(count)
            if live:
                view.update(data)
                ahead = data.time - (time.perf_counter() - wall_start)
                if ahead > 0:
                    time.sleep(ahead)  # pace the live view to real time
    return stepping


def _print_summary(s: dict) -> None:
    print(f"scene            {s['scene']}")
    print(f"simulated time   {s['simulated_s']:.3f} s")
    print(f"wall time        {s['wall_s']:.3f} s (stepping only)")
    print(f"real-time factor {s['real_time_factor']:.2f}x  ({s['wall_s'] / max(s['simulated_s'], 1e-12):.3f} wall s per simulated s)")
    for g in s["intestines"]:
        print(f"intestine '{g['name']}': length {g['final_length_m']:.4f} m (rest {g['rest_length_m']:.4f} m), "
              f"lowest axis point z = {g['lowest_point_m']:.4f} m, max speed {g['max_speed_m_s']:.3g} m/s, "
              f"divergences {g['divergences']}")
    if "png" in s:
        print(f"picture          {s['png']}")
    if "recording" in s:
        print(f"recording        {s['recording']} ({s['recording_frames']} frames, {s['recording_bytes'] / 1e6:.1f} MB)")
    sys.stdout.flush()


def view(scene: str) -> None:
    """Open MuJoCo's own interactive viewer (simulate: pause, reset, perturb, the actuators'
    sliders, the scene's cameras) on `scene`, the plugin loaded; returns when its window closes."""
    model = cli.load_model(scene)
    if not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY") and sys.platform.startswith("linux"):
        raise UserError("view needs a display (DISPLAY is not set); on a machine without one, "
                        f"`{PROG} run {scene} --png out.png` renders a picture and `--viewer meshcat` shows "
                        "the run in a browser", status=2)
    import mujoco.viewer

    if model.ncam > 0 and model.vis.global_.cameraid < 0:
        model.vis.global_.cameraid = 0  # the viewer opens from the scene's first camera, as the meshcat viewer does

    def loader():  # with its path, the viewer aligns its camera to the model's (it does not for a bare model)
        return model, mujoco.MjData(model), os.path.abspath(scene)

    mujoco.viewer.launch(loader=loader)


def _trace_and_score(task: str):
    """An on_step callback sampling viscera.assess's trace, and a function giving the score."""
    from viscera import assess
    tracer = []

    def on_step(env, time_step) -> None:
        if not tracer:
            tracer.append(assess.Tracer(env))
        tracer[0].sample(env)

    return on_step, lambda: assess.score(tracer[0].trace)


def print_score(score: dict) -> None:
    """The score's figures, one line per tool and one for the tissue."""
    from viscera import assess
    for line in assess.summary_lines(score):
        print(line)


def ticks(count: int) -> str:
    return f"{count} tick{'s' * (count != 1)}"


def load_policy(path: str, task: str, scene: str):
    """The policy file at `path` for `task` in `scene` (viscera.policy_file), or one line saying
    what is wrong with it (status 2), before any environment is built."""
    from viscera import policy_file
    try:
        learned = policy_file.load(path)
        learned.check_task(task, scene)
    except policy_file.PolicyFileError as error:
        raise UserError(f"--policy {error}", status=2) from None
    return learned


def play(task: str, seed: int, policy: str, time_limit_s: float | None, quiet: bool,
         out: str | None = None, scene: str = "abdomen") -> tuple[bool, dict]:
    """One whole episode of `task` (to its success, failure or time limit) played by a policy kind
    (recording.POLICIES) or a policy file (its path), with `out` saved for replay; prints its
    score and the verdict last. A policy file is checked (the file, then the environment it
    acts in) before the episode starts. Returns the success and the score."""
    from viscera import policy_file, recording
    if policy not in recording.POLICIES:
        policy = load_policy(policy, task, scene)
        if out and os.path.exists(out) and os.path.samefile(out, policy.path):
            raise UserError(f"--out {out}: that is the policy file (--policy); the recording would overwrite it",
                            status=2)
    on_step, score = _trace_and_score(task)
    try:
        made = recording.record(task, seed, policy, time_limit_s=time_limit_s, progress=not quiet, on_step=on_step,
                                scene=scene)
    except policy_file.PolicyFileError as error:  # the environment is not the one it was trained on
        raise UserError(f"--policy {error}", status=2) from None
    where = "" if scene == "abdomen" else f", {scene} scene"
    episode = (f"{task}{where}, seed {seed}, {made.policy} policy, {ticks(made.steps)} of "
               f"{made.control_timestep_s * 1e3:g} ms")
    if out:
        made.save(out)
        print(f"recording        {out} ({episode})")
    else:
        print(f"episode          {episode}")
    result = score()
    print_score(result)
    if out:
        print(f"final state      sha256 {made.final_state_sha256}")
    print(recording.verdict(task, made.success), flush=True)
    return made.success, result


def record(task: str, seed: int, policy: str, out: str, time_limit_s: float | None, quiet: bool,
           scene: str = "abdomen") -> dict:
    """play, the episode saved to `out`; returns the score."""
    return play(task, seed, policy, time_limit_s, quiet, out, scene)[1]


def replay(path: str, json_out: str | None, viewer: str | None, trajectory: str | None, quiet: bool,
           video: str | None = None) -> dict:
    import json

    from viscera import recording
    from viscera import video as video_module
    try:
        made = recording.load(path)
    except recording.RecordingError as error:
        raise UserError(str(error)) from None
    if video:
        try:
            video_module.check_encoder()
        except video_module.VideoError as error:
            raise UserError(str(error), status=2) from None
    on_step, score = _trace_and_score(made.task)
    show = None
    if viewer == "meshcat":
        on_step = _shown(on_step, made.control_timestep_s)
    filmed = _filmed(on_step, video, made.control_timestep_s) if video else on_step
    try:
        result = recording.replay(made, on_step=filmed, progress=not quiet and viewer is None)
    except recording.RecordingError as error:
        raise UserError(f"{path}: {error}") from None
    except video_module.VideoError as error:
        raise UserError(str(error)) from None
    finally:
        show = getattr(on_step, "view", None)
        if show and show[0] is not None:
            show[0].close()
        for part in getattr(filmed, "parts", ()):
            part.close()
    if not result.matches(made):
        raise UserError(f"{path}: the replay ended in another state (sha256 {result.final_state_sha256[:16]}..., "
                        f"recorded {made.final_state_sha256[:16]}...); it was recorded with "
                        f"viscera {made.versions.get('viscera', '?')}, mujoco {made.versions.get('mujoco', '?')}")
    values = score()
    where = "" if made.scene == "abdomen" else f", {made.scene} scene"
    print(f"replayed         {path} ({made.task}{where}, seed {made.seed}, {made.policy} policy, {ticks(result.steps)}): "
          "bit-identical")
    print_score(values)
    print(f"final state      sha256 {result.final_state_sha256}")
    if json_out:
        document = dict(values, final_state_sha256=result.final_state_sha256,
                        recording={"task": made.task, "seed": made.seed, "policy": made.policy, "steps": result.steps})
        with open(json_out, "w") as f:
            json.dump(document, f, indent=1)
        print(f"score            {json_out}")
    if video:
        frames = filmed.parts[0].frames
        print(f"video            {video} ({frames} frames, {1.0 / made.control_timestep_s:g} per second, "
              f"{video_module.SIZE} x {video_module.SIZE})")
    if trajectory:
        for tool, spec in recording.trajectories(made).items():
            name = trajectory_file(trajectory, tool)
            with open(name, "w") as f:
                json.dump(spec, f, indent=1)
            print(f"trajectory       {name} ({len(spec['waypoints'])} waypoints)")
    print(recording.verdict(made.task, result.success), flush=True)
    return values


def _filmed(on_step, path: str, control_timestep_s: float):
    """on_step that also writes the laparoscope's view, with the overlay, as a frame of the video
    at `path`, at the control rate (viscera.video); `.parts` are the writer and the frames, to close."""
    from viscera import video
    writer = video.VideoWriter(path, fps=1.0 / control_timestep_s)
    frames = video.LaparoscopeFrames()

    def step(env, time_step) -> None:
        on_step(env, time_step)
        writer.append(frames.frame(env))

    step.parts = (writer, frames)
    return step


def trajectory_file(pattern: str, tool: str) -> str:
    """OUT.json -> OUT_<tool>.json: one ToolTrajectory file per tool."""
    root, suffix = os.path.splitext(pattern)
    return f"{root}_{tool}{suffix}"


def _shown(on_step, control_timestep_s: float):
    """on_step that also shows the replay in a meshcat viewer, paced to real time."""
    from viscera.viewer import MeshcatViewer
    view = [None]
    start = [0.0]
    every = max(1, int(round(1.0 / (30.0 * control_timestep_s))))

    def step(env, time_step) -> None:
        on_step(env, time_step)
        physics = env.physics
        if view[0] is None:  # the first time step: the episode's model is built
            view[0] = MeshcatViewer(physics.model.ptr, camera=0 if physics.model.ncam else None)
            print(f"meshcat viewer: {view[0].url}", flush=True)
            start[0] = time.perf_counter()
        if int(round(physics.data.time / control_timestep_s)) % every == 0 or time_step.last():
            view[0].update(physics.data.ptr)
            ahead = physics.data.time - (time.perf_counter() - start[0])
            if ahead > 0:
                time.sleep(ahead)  # the replay plays at the rate it was recorded at

    step.view = view
    return step


SCENES = ("abdomen", "anatomical")  # viscera.tasks.scene.SCENES' names, without loading dm_control (tested)


def task_arguments(parser: argparse.ArgumentParser, seed_required: bool) -> None:
    """A task's episode: its name, seed and time limit (teleop, play, record)."""
    from viscera.task_registry import TASKS  # the names, without loading dm_control
    parser.add_argument("task", choices=tuple(TASKS), metavar="TASK", help=f"one of {', '.join(TASKS)}")
    if seed_required:
        parser.add_argument("--seed", type=cli.seed, required=True, help="the episode's seed (0 to 2^32 - 1)")
    else:
        parser.add_argument("--seed", type=cli.seed, default=0, help="the episode's seed (0 to 2^32 - 1, default 0)")
    parser.add_argument("--time-limit", type=cli.duration, help="the episode's length in simulated s (default: the task's)")
    parser.add_argument("--scene", choices=SCENES, default="abdomen",
                        help="the cavity: abdomen (the box, 3 m of bowel; default) or anatomical (curved walls, "
                             "5.06 m of small bowel framed by the colon)")


def policy_arguments(parser: argparse.ArgumentParser, required: bool) -> None:
    """The policy that plays a task's episode, and the output's options (play, record)."""
    from viscera.recording import POLICIES
    default = "" if required else ", the default"
    parser.add_argument("--policy", choices=cli.PolicyChoices(POLICIES), required=required, metavar="POLICY",
                        default=None if required else "scripted",
                        help=f"scripted (the task's script{default}), random (uniform actions, numpy's "
                        "default_rng(seed)), idle (the tools held withdrawn), or a policy file (a path ending "
                        "in .npz: a learned policy, docs/learning.md)")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")


def dataset(args: argparse.Namespace) -> dict:
    """The dataset command: every argument checked before the first episode, then a summary line."""
    policy, recordings = args.policy[0], None
    choices = ("scripted", "random", "idle", "recordings")
    from viscera.policy_file import is_path
    if policy not in choices and not is_path(policy):
        raise UserError(f"--policy {policy!r}: must be one of {', '.join(choices)}", status=2)
    if policy == "recordings":
        if len(args.policy) != 2:
            raise UserError("--policy recordings needs one folder: --policy recordings DIR", status=2)
        recordings = args.policy[1]
        if args.seeds is not None:
            raise UserError("--seeds with --policy recordings: a recording carries its own seed", status=2)
        for name, value in (("--scene", args.scene), ("--action-noise", args.action_noise or None)):
            if value is not None:
                raise UserError(f"{name} with --policy recordings: a recording replays in its own scene, as it "
                                "was done", status=2)
    elif len(args.policy) != 1:
        raise UserError(f"--policy {' '.join(args.policy)!r}: only 'recordings' takes a folder", status=2)
    if args.size is not None and not args.pixels:
        raise UserError(f"--size {args.size[0]}x{args.size[1]} needs --pixels (the images it sizes)", status=2)
    seeds = args.seeds if args.seeds is not None else range(args.episodes or 10)
    if args.episodes is not None and args.seeds is not None and args.episodes > len(seeds):
        raise UserError(f"--episodes {args.episodes} is more than --seeds {seeds.start}:{seeds.stop} gives "
                        f"({len(seeds)})", status=2)
    from viscera import datasets
    try:
        summary = datasets.write(args.task, args.out, args.format, demonstrator=policy, seeds=seeds,
                                 recordings=recordings, episodes_limit=args.episodes, scene=args.scene or "abdomen",
                                 pixels=args.pixels, size=args.size or (84, 84), workers=args.workers, progress=not args.quiet,
                                 action_noise=args.action_noise)
    except datasets.DatasetError as error:
        option = {"out": "--out", "recordings": "--policy recordings", "format": "--format", "seeds": "--seeds",
                  "action_noise": "--action-noise", "workers": "--workers", "episodes_limit": "--episodes",
                  "demonstrator": "--policy", "task": "TASK"}[error.argument]
        raise UserError(f"{option} {error.shown}: {error.problem}", status=2) from None
    print(f"wrote {summary['episodes']} episodes ({summary['frames']} frames, {summary['successes']} successful) "
          f"to {summary['out']} ({summary['format']}) in {summary['wall_s']:.1f} s: "
          f"{summary['episodes_per_hour_per_worker']:.0f} episodes per hour per worker")
    return summary


def build_parser() -> argparse.ArgumentParser:
    parser = cli.OneLineParser(prog=PROG, description="viscera: a real-time intestine simulator on MuJoCo. "
                               "Run an MJCF scene with intestines and print a summary, open it in MuJoCo's "
                               "viewer, drive a task's tools yourself (teleop), play a task's episode with a "
                               "policy, record an episode and replay it with its score.")
    from viscera.recording import versions
    parser.add_argument("--version", action="version",
                        version="viscera {viscera}, mujoco {mujoco}".format(**versions()))
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    run_parser = commands.add_parser("run", help="simulate an MJCF scene and print a summary",
                                     description="Simulate an MJCF scene and print a summary. Every option is "
                                     "checked before the first step.")
    run_parser.add_argument("scene", help="MJCF file, e.g. assets/scenes/fall_on_plane.xml")
    run_parser.add_argument("--duration", type=cli.duration, default=5.0, help="simulated seconds (default 5)")
    run_parser.add_argument("--png", type=cli.output_file(".png"), help="render the final state to this PNG file")
    run_parser.add_argument("--camera", help="the scene's camera (name or number) for --png and the viewer "
                            "(default: the scene's first camera; without one, a view of the whole scene)")
    run_parser.add_argument("--quiet", action="store_true", help="no progress bar")
    run_parser.add_argument("--viewer", choices=["meshcat"], help="show the run live in a browser (meshcat)")
    run_parser.add_argument("--hold", action="store_true",
                            help="after the run, keep the viewer serving the final state until Ctrl-C "
                            "(needs --viewer meshcat)")
    run_parser.add_argument("--record", type=cli.output_file(".html", ".htm"),
                            help="write a self-contained HTML recording of the run to this file")
    run_parser.add_argument("--record-fps", type=cli.positive_float_up_to(1e4, "frames per s", minimum=1e-3), default=10.0,
                            help="recorded frames per simulated second (default 10)")
    run_parser.add_argument("--host", default="127.0.0.1", help="address the viewer serves on (default: loopback only)")
    view_parser = commands.add_parser("view", help="open MuJoCo's interactive viewer on an MJCF scene",
                                      description="Open MuJoCo's interactive viewer (simulate) on an MJCF scene "
                                      "with the viscera plugin loaded and the intestine drawn, from the scene's "
                                      "first camera. Its Camera menu (or the [ and ] keys) switches cameras, "
                                      "Esc frees the camera. Needs a display. To drive a task's tools, use teleop.")
    view_parser.add_argument("scene", help="MJCF file, e.g. assets/scenes/abdomen.xml")

    from viscera.teleop.devices import DEVICES
    teleop_parser = commands.add_parser(
        "teleop", help="drive a task's tools and the laparoscope yourself, then get the score",
        description="Open a task's randomised episode through the laparoscope (held keys: teleop's own window; "
        "--keys step and the other devices: MuJoCo's viewer) and drive its tools and the scope with a device, in "
        "real time; the score is printed when the episode ends (success, time limit, or the window closed). Needs "
        "a display. docs/rehearsal.md has the bindings and the socket protocol.")
    task_arguments(teleop_parser, seed_required=False)
    teleop_parser.add_argument("--device", choices=DEVICES, default="keyboard",
                               help="what drives the tools (default keyboard; socket: an external haptic device)")
    teleop_parser.add_argument("--record", type=cli.output_file(".npz"),
                               help="save the session to this file, for replay")
    teleop_parser.add_argument("--port", type=cli.port, help="the socket device's UDP port on loopback (default 47000)")
    teleop_parser.add_argument("--haptic-cpu", type=int, metavar="CORE",
                               help="the socket device's server on this core only (0 is the first), at real-time "
                               "priority where allowed: put the haptic driver on the same core and nothing else")
    teleop_parser.add_argument("--camera", choices=("steer", "follow", "fixed"), default="steer",
                               help="steer: the laparoscope is the device's last tool (pitch, yaw, depth, roll), the "
                               "default; follow: an assistant keeps the active tool centred; fixed: it stays aimed")
    teleop_parser.add_argument("--keys", choices=("hold", "step"), default="hold",
                               help="the keyboard: hold a key to move at the tools' velocity limits, release it to "
                               "stop, in teleop's own window (the default); step: each press steps, in MuJoCo's viewer")
    teleop_parser.add_argument("--optics", choices=("0", "30"), default="0",
                               help="the laparoscope's optics: 0 (looks along its shaft, the default) or 30 degrees")
    play_parser = commands.add_parser(
        "play", help="play one whole episode of a task with a policy and say whether it succeeded",
        description="Play one whole episode of a task (its own time limit) with its scripted policy, random "
        "or idle actions, or a policy file, and print the score and the verdict. The exit status is 0 if the episode "
        "succeeded, 1 if not (2: a mistake in the command).")
    task_arguments(play_parser, seed_required=False)
    policy_arguments(play_parser, required=False)
    record_parser = commands.add_parser(
        "record", help="record an episode of a task played by a policy (no person), with its score",
        description="Run one episode of a task with a scripted, random or idle policy or a policy file, save it "
        "for replay (the policy file is not needed to replay it), and "
        "print its score, the final state's SHA-256 and the verdict.")
    task_arguments(record_parser, seed_required=True)
    record_parser.add_argument("--out", type=cli.output_file(".npz"), required=True, help="the recording (.npz)")
    policy_arguments(record_parser, required=True)
    dataset_parser = commands.add_parser(
        "dataset", help="collect demonstrations into a LeRobot or Minari dataset",
        description="Collect episodes of a task, from a demonstrator on a range of seeds or from recordings, "
        "in worker processes, and write them with LeRobot's or Minari's own writer (docs/learning.md has the "
        "fields). The dataset appears at --out only once whole.")
    from viscera.task_registry import TASKS
    dataset_parser.add_argument("task", choices=tuple(TASKS), metavar="TASK", help=f"one of {', '.join(TASKS)}")
    dataset_parser.add_argument("--policy", nargs="+", default=["scripted"], metavar="POLICY",
                                help="scripted (the default), random, idle, 'recordings DIR': the recordings "
                                "(*.npz) of a folder, replayed, or a policy file (a path ending in .npz)")
    dataset_parser.add_argument("--episodes", type=cli.positive_int,
                                help="how many episodes (default: one per seed, or per recording)")
    dataset_parser.add_argument("--seeds", type=cli.seed_range,
                                help="the task seeds A:B, A to B - 1 (default 0:EPISODES, or 0:10)")
    dataset_parser.add_argument("--format", choices=("lerobot", "minari"), required=True,
                                help="lerobot (LeRobotDataset v3: parquet, the RGB as video) or minari (HDF5)")
    dataset_parser.add_argument("--out", required=True, help="the dataset's path, new (a folder is made there)")
    dataset_parser.add_argument("--pixels", action="store_true",
                                help="add the laparoscope's RGB (video in LeRobot), depth and segmentation")
    dataset_parser.add_argument("--size", type=cli.image_size,
                                help="the images' HEIGHTxWIDTH in pixels (default 84x84)")
    dataset_parser.add_argument("--scene", choices=SCENES, help="the cavity (default abdomen; a recording has its own)")
    dataset_parser.add_argument("--action-noise", type=cli.fraction, default=0.0, metavar="SIGMA",
                                help="noise (0 to 1, normalised action units) added to the actions taken while "
                                "the demonstrator corrects, its commands kept as demonstrator_action (default 0)")
    dataset_parser.add_argument("--workers", type=cli.positive_int, default=1,
                                help="worker processes collecting episodes (default 1)")
    dataset_parser.add_argument("--quiet", action="store_true", help="no progress bar")
    replay_parser = commands.add_parser(
        "replay", help="replay a recording bit for bit and print its score",
        description="Replay a recording (teleop --record or record) bit for bit, check it ends in the recorded "
        "state, print the score and the verdict.")
    replay_parser.add_argument("recording", type=cli.input_file, help="a recording (.npz)")
    replay_parser.add_argument("--json", type=cli.output_file(".json"),
                               help="write the score and final_state_sha256 to this JSON file")
    replay_parser.add_argument("--viewer", choices=["meshcat"], help="show the replay in a browser (meshcat), "
                               "at the rate it was recorded at")
    replay_parser.add_argument("--trajectory", type=cli.output_file(".json"),
                               help="write each tool's motion as a ToolTrajectory file: OUT.json gives "
                               "OUT_<tool>.json per tool")
    replay_parser.add_argument("--video", type=cli.output_file(".mp4"),
                               help="write the laparoscope's view with the overlay to this MP4, one frame per "
                               "control step, at the recording's control rate (needs imageio-ffmpeg: the video extra)")
    replay_parser.add_argument("--quiet", action="store_true", help="no progress bar")
    report_parser = commands.add_parser(
        "report", help="replay recordings and write one HTML page of the attempts against the reference band",
        description="Check every recording, replay each bit for bit with its score, and write one self-contained "
        "HTML page (it opens offline): each attempt's score against the reference band, the learning curve of a "
        "task's attempts (in the order given), and each attempt's force, pinch and tool paths (needs matplotlib: "
        "the report extra).")
    report_parser.add_argument("recordings", nargs="+", type=cli.input_file, metavar="FILE",
                               help="recordings (.npz), in the order they were attempted")
    report_parser.add_argument("--out", type=cli.output_file(".html", ".htm"), required=True, help="the page")
    report_parser.add_argument("--quiet", action="store_true", help="no progress bar")
    for command_parser in commands.choices.values():  # each command's last option, and its name for main
        command_parser.add_argument("--verbose", action="store_true", help="print the traceback of an error too")
        command_parser.set_defaults(command_parser=command_parser)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args, unknown = parser.parse_known_args(argv)
    cli.check_unknown(args.command_parser, unknown)  # a misspelled option of `run` gets run's line, not the top level's
    with cli.user_errors(f"{PROG} {args.command}", args.verbose):  # the prefix argparse's errors have
        if args.command == "view":
            view(args.scene)
        elif args.command == "teleop":
            for flag, given in (("--port", args.port), ("--haptic-cpu", args.haptic_cpu)):
                if given is not None and args.device != "socket":  # else silently unused
                    raise UserError(f"{flag} is the socket device's; it needs --device socket, not {args.device}",
                                    status=2)
            from viscera.teleop.app import teleop
            teleop(args.task, args.seed, args.device, args.record, args.port, args.time_limit, args.scene,
                   args.camera, float(args.optics), args.keys, args.haptic_cpu)
        elif args.command == "play":
            success, _ = play(args.task, args.seed, args.policy, args.time_limit, args.quiet, scene=args.scene)
            return 0 if success else 1
        elif args.command == "record":
            record(args.task, args.seed, args.policy, args.out, args.time_limit, args.quiet, args.scene)
        elif args.command == "dataset":
            dataset(args)
        elif args.command == "report":
            from viscera import report
            try:
                summary = report.write(args.recordings, args.out, progress=not args.quiet)
            except report.ReportError as error:
                raise UserError(str(error), status=2 if "pip install" in str(error) else 1) from None
            print(f"wrote {summary['out']}: {summary['attempts']} attempts of {', '.join(summary['tasks'])} "
                  f"({summary['bytes'] / 1024:.0f} kB)")
            for path in summary["not_bit_identical"]:
                print(f"warning: {path} replayed to another final state than it recorded (another viscera?)",
                      file=sys.stderr)
        elif args.command == "replay":
            replay(args.recording, args.json, args.viewer, args.trajectory, args.quiet, args.video)
        else:
            run(args.scene, args.duration, args.png, args.camera, args.quiet, args.viewer, args.record,
                args.record_fps, args.host, args.hold, report=_print_summary)
    return 0


if __name__ == "__main__":
    sys.exit(main())
