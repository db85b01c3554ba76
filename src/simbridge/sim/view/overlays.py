"""What the view draws on demand over the bodies: TF frames and contact points.

Both are off until their checkbox is ticked, so an unwatched overlay costs nothing; when
on, the streaming thread updates them with the pose snapshot it already took.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import mujoco
import numpy as np

from simbridge.sim.view.shapes import body_names

if TYPE_CHECKING:
    import viser

__all__ = ["CONTACT_RGB", "ContactPoints", "TfFrames"]

CONTACT_RGB = (255, 0, 255)
"""Contact points are drawn magenta, a colour no shipped scene uses."""


class TfFrames:
    """An axes triad per body (the TF tree's frames), shown while the checkbox is ticked."""

    def __init__(self, server: viser.ViserServer, axes_length: float = 0.12) -> None:
        self.server = server
        self.axes_length = axes_length
        self.frames: dict[int, Any] = {}
        """Body id -> the scene's frame handle, while shown."""
        self._names: list[str] = []
        self.checkbox = server.gui.add_checkbox("TF frames", initial_value=False)

    @property
    def enabled(self) -> bool:
        """Whether the page asks for the frames."""
        return bool(self.checkbox.value)

    def reset(self, model: mujoco.MjModel) -> None:
        """Forget the frames of the previous world (the scene was cleared)."""
        self.frames.clear()
        self._names = body_names(model)

    def update(self, xpos: np.ndarray, xquat: np.ndarray, moved: list[int]) -> None:
        """Add, move or remove the frames to match the checkbox and the snapshot."""
        if not self.enabled:
            for handle in self.frames.values():
                handle.remove()
            self.frames.clear()
            return
        scene = self.server.scene
        for body in range(1, len(self._names)):
            if body not in self.frames:
                self.frames[body] = scene.add_frame(
                    f"/tf/{self._names[body]}",
                    axes_length=self.axes_length,
                    axes_radius=self.axes_length / 20,
                    position=xpos[body],
                    wxyz=xquat[body],
                )
        for body in moved:
            if body in self.frames:
                handle = self.frames[body]
                handle.position = xpos[body]
                handle.wxyz = xquat[body]


class ContactPoints:
    """The active contacts as points, shown while the checkbox is ticked."""

    def __init__(self, server: viser.ViserServer, point_size: float = 0.025) -> None:
        self.server = server
        self.point_size = point_size
        self.handle: Any = None
        self.count = 0
        """Contacts drawn in the last update."""
        self.checkbox = server.gui.add_checkbox("Contact points", initial_value=False)

    def reset(self) -> None:
        """Forget the previous world's points (the scene was cleared)."""
        self.handle, self.count = None, 0

    def update(self, data: mujoco.MjData) -> None:
        """Draw the contacts of `data` now (a copy; the physics keeps stepping)."""
        if not self.checkbox.value:
            if self.handle is not None:
                self.handle.remove()
                self.reset()
            return
        points = np.array(data.contact.pos[: int(data.ncon)], dtype=np.float32).reshape(-1, 3)
        self.count = len(points)
        if self.handle is not None and self.count == 0:
            self.handle.visible = False
            return
        if self.count:
            self.handle = self.server.scene.add_point_cloud(
                "/contacts",
                points,
                colors=CONTACT_RGB,
                point_size=self.point_size,
                point_shape="circle",
                point_shading="flat",
            )
