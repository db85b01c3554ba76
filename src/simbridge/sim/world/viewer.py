"""MuJoCo's own passive viewer window for `World.run(viewer=True)` (needs a display)."""

from __future__ import annotations

import os
from typing import TYPE_CHECKING

import mujoco

from simbridge.errors import SimError

if TYPE_CHECKING:
    import mujoco.viewer

__all__ = ["open_viewer"]


def open_viewer(model: mujoco.MjModel, data: mujoco.MjData) -> mujoco.viewer.Handle:
    """A passive viewer window on `model` and `data`; `SimError` without a display or
    when GLFW cannot open one."""
    if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        raise SimError("the viewer needs a display, but DISPLAY is not set (run headless)")
    import mujoco.viewer  # noqa: PLC0415 - pulls in GLFW, only wanted with a display

    try:
        return mujoco.viewer.launch_passive(model, data)
    except Exception as exc:  # GLFW init failures surface as RuntimeError and others
        raise SimError(f"could not open the MuJoCo viewer: {exc}") from None
