"""Offscreen video of a run: frames rendered headless, written as a GIF (Pillow) or MP4.

MP4 frames are piped to ffmpeg: the one on PATH, else the binary the imageio-ffmpeg
package ships. GIF needs nothing more.
"""

from __future__ import annotations

import math
import shutil
import subprocess
from pathlib import Path

import numpy as np
import numpy.typing as npt
from PIL import Image

from simbridge.errors import AppError
from simbridge.sim import World
from simbridge.sim.sensors import OffscreenRenderer, Pose

__all__ = ["VIDEO_FORMATS", "VideoRecorder", "check_video_path"]

VIDEO_FORMATS = (".gif", ".mp4")
_FOVY = math.radians(45.0)


def _look_at(eye: tuple[float, float, float], target: tuple[float, float, float]) -> Pose:
    """A camera pose at ``eye`` looking at ``target`` (ROS camera body axes: x forward, z up)."""
    position = np.array(eye, dtype=np.float64)
    forward = np.array(target, dtype=np.float64) - position
    forward /= np.linalg.norm(forward)
    left = np.cross([0.0, 0.0, 1.0], forward)
    left /= np.linalg.norm(left)
    up = np.cross(forward, left)
    return Pose(position, np.column_stack([forward, left, up]))


def ffmpeg_executable() -> str | None:
    """An ffmpeg to encode MP4 with: PATH first, then imageio-ffmpeg's bundled binary."""
    found = shutil.which("ffmpeg")
    if found is not None:
        return found
    try:
        import imageio_ffmpeg  # noqa: PLC0415 - optional, heavy only when MP4 is asked for

        return str(imageio_ffmpeg.get_ffmpeg_exe())
    except (ImportError, RuntimeError):
        return None


def check_video_path(path: str | Path) -> Path:
    """Validate the output path before the run: known suffix, encoder available, folder exists."""
    out = Path(path)
    suffix = out.suffix.lower()
    if suffix not in VIDEO_FORMATS:
        raise AppError(
            f"video {str(out)!r}: unknown format {suffix or '(none)'!r}; "
            f"use one of {', '.join(VIDEO_FORMATS)}"
        )
    if suffix == ".mp4" and ffmpeg_executable() is None:
        raise AppError(
            f"video {str(out)!r}: writing MP4 needs ffmpeg (on PATH or from the imageio-ffmpeg "
            "package); install one or ask for a .gif instead"
        )
    if not out.parent.is_dir():
        raise AppError(f"video {str(out)!r}: folder {str(out.parent)!r} does not exist")
    return out


class VideoRecorder:
    """Captures frames of a World at ``fps`` of simulated time from a fixed viewpoint.

    Rendering goes through the sensors' OffscreenRenderer, which picks the headless GL
    backend (MUJOCO_GL, else EGL, else OSMesa); shadows stay off (5x slower on OSMesa).
    """

    def __init__(
        self,
        world: World,
        path: str | Path,
        fps: float = 15.0,
        width: int = 480,
        height: int = 360,
        *,
        eye: tuple[float, float, float] = (0.8, 0.45, 0.42),
        target: tuple[float, float, float] = (0.12, 0.0, 0.06),
    ) -> None:
        """``eye`` and ``target`` (world, m) place the camera (default: the pick-and-place
        table seen from the front right)."""
        self.path = check_video_path(path)
        if fps <= 0:
            raise AppError(f"video fps must be > 0, got {fps}")
        self.world = world
        self.fps = fps
        self._renderer = OffscreenRenderer(world.model, width, height)
        self._view = _look_at(eye=eye, target=target)
        self._frames: list[npt.NDArray[np.uint8]] = []
        self._next = 0.0

    @property
    def frame_count(self) -> int:
        """Frames captured so far."""
        return len(self._frames)

    def maybe_capture(self) -> None:
        """Capture a frame when the world's time reached the next frame time."""
        if self.world.time + 1e-9 >= self._next:
            frame = self._renderer.render_rgb(self.world.data, self._view, _FOVY, 0.05, 10.0)
            self._frames.append(frame)
            self._next += 1.0 / self.fps

    def save(self) -> Path:
        """Write the frames to the path and release the renderer."""
        self._renderer.close()
        if not self._frames:
            raise AppError(f"video {str(self.path)!r}: no frames were captured")
        if self.path.suffix.lower() == ".gif":
            images = [Image.fromarray(f) for f in self._frames]
            images[0].save(
                self.path,
                save_all=True,
                append_images=images[1:],
                duration=round(1000 / self.fps),
                loop=0,
            )
        else:
            self._write_mp4()
        return self.path

    def _write_mp4(self) -> None:
        height, width = self._frames[0].shape[:2]
        ffmpeg = ffmpeg_executable()
        if ffmpeg is None:
            raise AppError("writing MP4 needs ffmpeg (on PATH or from the imageio-ffmpeg package)")
        command = [
            ffmpeg, "-y", "-loglevel", "error", "-f", "rawvideo", "-pix_fmt", "rgb24",
            "-s", f"{width}x{height}", "-r", f"{self.fps:g}", "-i", "-",
            "-pix_fmt", "yuv420p", "-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2", str(self.path),
        ]  # fmt: skip
        frames = b"".join(f.tobytes() for f in self._frames)
        done = subprocess.run(command, input=frames, capture_output=True, check=False)
        if done.returncode != 0:
            raise AppError(f"ffmpeg could not write {str(self.path)!r}: {done.stderr.decode()}")
