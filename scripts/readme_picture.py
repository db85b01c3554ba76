"""Render docs/pick-and-place.png, the README's picture: a frame of the pick-and-place demo
(the arm lifting the cube) rendered offscreen by MuJoCo, as `--video` renders its frames.

Usage: MUJOCO_GL=osmesa .venv/bin/python scripts/readme_picture.py [OUT.png]
"""

from __future__ import annotations

import sys
from functools import partial
from pathlib import Path

from PIL import Image

from simbridge.apps.pick_and_place import demo, run_pick_and_place
from simbridge.apps.pick_and_place.video import VideoRecorder

OUT = Path(sys.argv[1] if len(sys.argv) > 1 else "docs/pick-and-place.png")
SHARE = 0.55
"""Where in the run the frame is taken (a share of the frames): the cube in the air."""


class _Still(VideoRecorder):
    """Keeps one frame as a PNG instead of writing a video."""

    def save(self) -> Path:
        self._renderer.close()
        frame = self._frames[int(SHARE * (len(self._frames) - 1))]
        Image.fromarray(frame).save(OUT, optimize=True)
        return OUT


demo.VideoRecorder = partial(  # type: ignore[misc]
    _Still, fps=10.0, width=800, height=450, eye=(0.72, 0.62, 0.5), target=(0.12, -0.02, 0.14)
)
result = run_pick_and_place("local", None, "unused.gif", progress=None)
print(f"wrote {OUT} ({'success' if result.success else 'FAILED'})")
