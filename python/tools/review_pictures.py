"""The review pictures of docs/rehearsal.md: a frame of a replay video and a report page of five
attempts, made through the command line a trainee runs.

    python python/tools/review_pictures.py [--out docs/rehearsal]

Five attempts at grasp_lift, in order: idle for 5 s, random actions for 5 s (both fail), then the
scripted policy on seeds 3, 4 and 5 (they succeed): made by policies, not a person, to show every
part of the page. Each is recorded (`python -m viscera record`), the five are reported
(`python -m viscera report ... --out report.html`, shot in headless Chromium, 1280 x 1700: OUT/
report.png), and the third is replayed with `--video` (its frame at 2.5 s: OUT/replay_frame.png).
"""

from __future__ import annotations

import argparse
import pathlib
import shutil
import subprocess
import sys
import tempfile

import numpy as np

ATTEMPTS = (("idle", 1, ["--time-limit", "5"]), ("random", 2, ["--time-limit", "5"]), ("scripted", 3, []),
            ("scripted", 4, []), ("scripted", 5, []))
FRAME_S = 2.5


def viscera(*args) -> str:
    done = subprocess.run([sys.executable, "-m", "viscera", *args], capture_output=True, text=True, timeout=1200)
    if done.returncode not in (0, 1):
        raise SystemExit(f"python -m viscera {' '.join(args)} failed: {done.stderr.strip()}")
    return done.stdout


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python python/tools/review_pictures.py", description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=pathlib.Path, default=pathlib.Path("docs") / "rehearsal")
    args = parser.parse_args(argv)
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if chromium is None:
        raise SystemExit("needs chromium (Debian's package) for the report's screenshot")
    import imageio_ffmpeg
    from PIL import Image
    with tempfile.TemporaryDirectory() as folder:
        paths = []
        for number, (policy, seed, extra) in enumerate(ATTEMPTS, start=1):
            path = pathlib.Path(folder) / f"attempt{number}.npz"
            viscera("record", "grasp_lift", "--seed", str(seed), "--policy", policy, "--out", str(path), "--quiet", *extra)
            paths.append(str(path))
        page = pathlib.Path(folder) / "report.html"
        print(viscera("report", *paths, "--out", str(page), "--quiet").strip())
        shot = args.out / "report.png"
        subprocess.run([chromium, "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                        "--disable-component-update", "--disable-sync", "--no-first-run",
                        f"--user-data-dir={tempfile.mkdtemp()}", f"--screenshot={shot}", "--window-size=1280,1700",
                        "--virtual-time-budget=3000", page.as_uri()], capture_output=True, timeout=180, check=True)
        print(f"wrote {shot}")
        movie = pathlib.Path(folder) / "attempt3.mp4"
        viscera("replay", paths[2], "--video", str(movie), "--quiet")
        reader = imageio_ffmpeg.read_frames(str(movie))
        meta = next(reader)
        wanted = int(round(FRAME_S * meta["fps"]))
        for index, frame in enumerate(reader):
            if index == wanted:
                width, height = meta["size"]
                Image.fromarray(np.frombuffer(frame, dtype=np.uint8).reshape(height, width, 3)).save(
                    args.out / "replay_frame.png")
                print(f"wrote {args.out / 'replay_frame.png'} (frame {index}, {FRAME_S} s)")
                break
        reader.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
