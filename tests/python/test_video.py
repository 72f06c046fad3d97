"""`python -m viscera replay FILE --video OUT.mp4`: the laparoscope's view as the trainee saw it,
one frame per control step at the recording's control rate, with the overlay."""

import subprocess
import sys

import numpy as np
import pytest

from viscera import recording, video

imageio_ffmpeg = pytest.importorskip("imageio_ffmpeg")


def run(*args, **kwargs) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "viscera", *args], capture_output=True, text=True, timeout=600,
                          **kwargs)


def decoded(path) -> tuple[dict, list[np.ndarray]]:
    reader = imageio_ffmpeg.read_frames(str(path))
    meta = next(reader)
    width, height = meta["size"]
    return meta, [np.frombuffer(frame, dtype=np.uint8).reshape(height, width, 3) for frame in reader]


@pytest.fixture(scope="module")
def short_recording(tmp_path_factory):
    path = tmp_path_factory.mktemp("video") / "grasp_lift.npz"
    done = run("record", "grasp_lift", "--seed", "3", "--policy", "scripted", "--time-limit", "2", "--out", str(path),
               "--quiet")
    assert done.returncode in (0, 1), done.stderr
    return path


def test_the_video_has_a_frame_per_control_step_of_what_the_laparoscope_saw(short_recording, tmp_path):
    out = tmp_path / "attempt.mp4"
    done = run("replay", str(short_recording), "--video", str(out), "--quiet")
    assert done.returncode in (0, 1), done.stderr
    made = recording.load(short_recording)
    meta, frames = decoded(out)
    assert len(frames) == made.steps + 1  # the reset's frame, then one per control step
    assert meta["fps"] == pytest.approx(1.0 / made.control_timestep_s)
    assert meta["size"] == (video.SIZE, video.SIZE)
    assert f"({made.steps + 1} frames, 50 per second, {video.SIZE} x {video.SIZE})" in done.stdout
    # the same steps replayed here, rendered without the encoder: the video shows them (H.264 is lossy)
    wanted = {0: None, made.steps // 2: None, made.steps: None}
    camera = video.LaparoscopeFrames()
    seen = [0]

    def keep(env, time_step):
        if seen[0] in wanted:
            wanted[seen[0]] = camera.frame(env)
        seen[0] += 1

    try:
        recording.replay(made, on_step=keep)
    finally:
        camera.close()
    for index, rendered in wanted.items():
        difference = np.abs(frames[index].astype(int) - rendered.astype(int)).mean()
        assert difference < 6.0, (index, difference)
    first, last = frames[0].astype(int), frames[-1].astype(int)
    assert np.abs(first - last).mean() > 2.0  # the scene moved: not one frame repeated
    middle = first[video.SIZE // 4:, :]  # below the overlay: the tissue, reddish
    assert (middle[..., 0] > middle[..., 2] + 30).mean() > 0.2
    top = first[:20, :]  # the overlay's dark band, with white text on it
    assert top.mean() < middle.mean() and (top.min(axis=2) > 200).any()


def test_a_bad_video_path_or_a_missing_encoder_is_one_line_before_the_replay(short_recording, tmp_path):
    done = run("replay", str(short_recording), "--video", str(tmp_path / "attempt.avi"))
    assert done.returncode == 2 and len(done.stderr.strip().splitlines()) == 1, done.stderr
    assert "attempt.avi" in done.stderr and ".mp4" in done.stderr
    hidden = ("import sys; sys.modules['imageio_ffmpeg'] = None; from viscera.__main__ import main; "
              f"sys.exit(main(['replay', {str(short_recording)!r}, '--video', {str(tmp_path / 'a.mp4')!r}]))")
    done = subprocess.run([sys.executable, "-c", hidden], capture_output=True, text=True, timeout=600)
    assert done.returncode == 2, done.stderr
    assert len(done.stderr.strip().splitlines()) == 1 and "imageio-ffmpeg" in done.stderr, done.stderr
    assert "replayed" not in done.stdout and not (tmp_path / "a.mp4").exists()
