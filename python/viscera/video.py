"""The laparoscope's view of an episode as a video: `python -m viscera replay FILE --video OUT.mp4`.

    writer = VideoWriter("attempt.mp4", fps=100)        # needs imageio-ffmpeg: pip install ".[video]"
    frames = LaparoscopeFrames()                         # then, after the reset and after every step:
    writer.append(frames.frame(env))                     # (SIZE, SIZE, 3) uint8, the overlay drawn on it
    writer.close(); frames.close()

A frame is the laparoscope's image as the trainee's viewer shows it (viscera.pixels.Camera: the
scope's own light on, no shadows), SIZE x SIZE pixels, with the teleop viewer's overlay written on
it: the time, each tool's force on the tissue and its hold with the pinch, and a warning line
where a force or a pinch passes its limit (viscera.assess's constants). One frame per control step, at the recording's control rate: a teleop recording at
100 frames per second, a scripted one at 50. Encoded as H.264 in yuv420p (what browsers and
players read) by the ffmpeg that imageio-ffmpeg ships; a frame of the abdomen renders in about
10 to 20 ms on software OpenGL.
"""

from __future__ import annotations

import numpy as np

from viscera import assess

SIZE = 480               # pixels, a side of the square frame (a multiple of 16, as H.264 blocks are)
TEXT_RGB = (255, 255, 255)
WARNING_RGB = (255, 80, 60)
SHADE_ALPHA = 150        # of 255: the dark band behind the text, so it reads on pale tissue


class VideoError(RuntimeError):
    """The encoder is missing or failed: one line for the command line."""


def check_encoder() -> None:
    """Raise VideoError (one line) if imageio-ffmpeg, the encoder, is not installed: before a replay starts."""
    try:
        import imageio_ffmpeg  # noqa: F401
    except ImportError:
        raise VideoError('--video needs imageio-ffmpeg, which encodes the frames: pip install "viscera[video]" '
                         '(from a source tree: pip install ".[video]")') from None


class VideoWriter:
    """An H.264 MP4 of (SIZE, SIZE, 3) uint8 frames at `fps` frames per second."""

    def __init__(self, path: str, fps: float, size: int = SIZE):
        check_encoder()
        import imageio_ffmpeg
        self.path, self.size, self.frames = path, size, 0
        self._writer = imageio_ffmpeg.write_frames(path, (size, size), fps=fps, codec="libx264", pix_fmt_in="rgb24",
                                                   pix_fmt_out="yuv420p", macro_block_size=16,
                                                   output_params=["-preset", "veryfast", "-crf", "23"])
        self._writer.send(None)  # start ffmpeg

    def append(self, frame: np.ndarray) -> None:
        if frame.shape != (self.size, self.size, 3) or frame.dtype != np.uint8:
            raise ValueError(f"a frame must be ({self.size}, {self.size}, 3) uint8, got {frame.shape} {frame.dtype}")
        try:
            self._writer.send(np.ascontiguousarray(frame).tobytes())
        except (OSError, RuntimeError) as error:
            raise VideoError(f"{self.path}: the encoder stopped: {str(error).splitlines()[0]}") from None
        self.frames += 1

    def close(self) -> None:
        if self._writer is not None:
            self._writer.close()
            self._writer = None


class LaparoscopeFrames:
    """Frames of the laparoscope with the overlay (see the module doc); one GL context, kept."""

    def __init__(self, size: int = SIZE):
        from viscera.pixels import Camera
        self.size = size
        self.camera = Camera(width=size, height=size, camera="laparoscope")
        self._font = None

    def close(self) -> None:
        self.camera.close()

    def frame(self, env) -> np.ndarray:
        """The laparoscope's image of `env`'s physics now, the overlay written on it."""
        from PIL import Image, ImageDraw
        image = Image.fromarray(self.camera.render_rgb(env.physics)).convert("RGBA")
        lines, warnings = overlay_lines(env)
        shade = Image.new("RGBA", image.size, (0, 0, 0, 0))
        draw = ImageDraw.Draw(shade)
        font = self._font_of_size()
        height = font.size + 3
        draw.rectangle((0, 0, self.size, 6 + height * len(lines)), fill=(0, 0, 0, SHADE_ALPHA))
        if warnings:
            draw.rectangle((0, self.size - 6 - height * len(warnings), self.size, self.size),
                           fill=(0, 0, 0, SHADE_ALPHA))
        image = Image.alpha_composite(image, shade)
        draw = ImageDraw.Draw(image)
        for row, line in enumerate(lines):
            draw.text((6, 3 + row * height), line, fill=TEXT_RGB, font=font)
        for row, line in enumerate(warnings):
            draw.text((6, self.size - 3 - height * (len(warnings) - row)), line, fill=WARNING_RGB, font=font)
        return np.asarray(image.convert("RGB"))

    def _font_of_size(self):
        if self._font is None:
            from PIL import ImageFont
            self._font = ImageFont.load_default(size=max(10, self.size // 32))
        return self._font


def overlay_lines(env) -> tuple[list[str], list[str]]:
    """The overlay's lines (the time, then each tool's force and hold) and its warnings, for
    `env` now: what the teleop viewer shows, without the bindings."""
    physics = env.physics
    data = physics.data.ptr
    limit = float(env.task.TIME_LIMIT_S)
    lines = [f"{env.task.NAME}   {data.time:5.2f} / {limit:.0f} s"]
    pinch = assess.pinches(physics)
    holding = {grasp.site.removesuffix("_tip"): grasp.holding for grasp in physics.intestine().grasps(data)}
    warnings = []
    for tool in physics.tools():
        force = float(np.linalg.norm(physics.named.data.sensordata[f"{tool}_force"][:3]))
        held = f"   holding, pinch {pinch.get(tool, 0.0):.1f} N" if holding.get(tool) else ""
        lines.append(f"{tool:14s} {force:5.2f} N{held}")
        if force > assess.TRACTION_LIMIT_N:
            warnings.append(f"{tool}: {force:.1f} N on the tissue, over its {assess.TRACTION_LIMIT_N:g} N limit")
        if pinch.get(tool, 0.0) > assess.PERFORATION_PINCH_N:
            warnings.append(f"{tool}: pinch {pinch[tool]:.1f} N, over perforation ({assess.PERFORATION_PINCH_N:g} N)")
    worst, _, torn = assess.damage_summary(physics.intestine(), data)
    lines.append(f"{'bowel wall':14s} bruise {worst:.2f}" + (f"   PERFORATED ({len(torn)})" if torn else ""))
    if torn:
        warnings.append(f"the bowel is perforated ({len(torn)}): the episode has failed")
    return lines, warnings
