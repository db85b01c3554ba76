"""RGB, metric depth and segmentation of one camera view, with MuJoCo's classic renderer
(`mujoco.Renderer`; its segmentation mode gives object id and type per pixel)."""

from __future__ import annotations

import atexit
import math
import weakref
from dataclasses import dataclass

import mujoco
import numpy as np
from numpy.typing import NDArray

from simbridge.errors import PerceptionError
from simbridge.perception.camera import CameraView
from simbridge.sim.sensors import configure_gl

__all__ = ["RenderSettings", "Rendered", "ViewRenderer"]

_OPEN: weakref.WeakSet[ViewRenderer] = weakref.WeakSet()


@atexit.register
def _close_at_exit() -> None:
    """Free GL contexts nobody closed while PyOpenGL still works (see sim.sensors.offscreen)."""
    for renderer in list(_OPEN):
        renderer.close()


@dataclass(frozen=True)
class RenderSettings:
    """How frames are drawn: clipping planes (m) and the classic renderer's effects."""

    near: float = 0.01
    far: float = 50.0
    shadows: bool = True
    reflections: bool = False
    multisamples: int = 4
    """Multisample anti-aliasing of the offscreen buffer (MuJoCo's default 4; 0: none,
    much faster on a CPU)."""


@dataclass
class Rendered:
    """One view's images (None where not asked for)."""

    rgb: NDArray[np.uint8] | None
    depth: NDArray[np.float32] | None
    """z distance along the optical axis (m); 0 where nothing was hit."""
    segmentation: NDArray[np.int32] | None
    """(H, W, 2): MuJoCo object id and object type; (-1, -1) where nothing was hit."""


class ViewRenderer:
    """Renders views of one size; the model's depth range is set to `settings`' planes."""

    def __init__(
        self, model: mujoco.MjModel, width: int, height: int, settings: RenderSettings
    ) -> None:
        configure_gl()
        if not 0 < settings.near < settings.far:
            raise PerceptionError(
                f"render: need 0 < near < far, got {settings.near}, {settings.far}"
            )
        extent = float(model.stat.extent)
        model.vis.map.znear = settings.near / extent
        model.vis.map.zfar = settings.far / extent
        model.vis.quality.offsamples = settings.multisamples
        model.vis.global_.offwidth = max(int(model.vis.global_.offwidth), width)
        model.vis.global_.offheight = max(int(model.vis.global_.offheight), height)
        self.width, self.height = width, height
        self.settings = settings
        # What mujoco.Renderer uses to linearise depth.
        self.near = float(model.vis.map.znear) * extent
        self.far = float(model.vis.map.zfar) * extent
        self._renderer: mujoco.Renderer | None = mujoco.Renderer(model, height, width)
        _OPEN.add(self)
        scene = self._renderer.scene
        scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = settings.shadows
        scene.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = settings.reflections
        self._option = mujoco.MjvOption()
        self._option.sitegroup[:] = 0  # sites are markers, not things a camera sees
        self._camera = mujoco.MjvCamera()
        mujoco.mjv_defaultFreeCamera(model, self._camera)

    def render(
        self, data: mujoco.MjData, view: CameraView, *, rgb: bool, depth: bool, segmentation: bool
    ) -> Rendered:
        """The images asked for, of `data` seen from `view`."""
        renderer = self._renderer
        if renderer is None:
            raise PerceptionError("render: the renderer was closed")
        # MuJoCo lays out infinite planes (and the headlight) around the scene's camera,
        # partly the one of the previous frame: set ours before and after the update, and
        # aim the free camera the same way, so a frame never depends on the one before.
        for glcam in renderer.scene.camera:
            view.apply_to(glcam, self.near, self.far)
        forward = view.rotation[:, 2]
        self._camera.lookat[:] = view.position + forward
        self._camera.distance = 1.0
        self._camera.azimuth = math.degrees(math.atan2(forward[1], forward[0]))
        self._camera.elevation = math.degrees(math.asin(max(-1.0, min(1.0, float(forward[2])))))
        renderer.update_scene(data, self._camera, self._option)
        for glcam in renderer.scene.camera:
            view.apply_to(glcam, self.near, self.far)
        colour = seg = dist = None
        if rgb:
            renderer.disable_depth_rendering()
            renderer.disable_segmentation_rendering()
            colour = renderer.render()
        if segmentation:
            renderer.enable_segmentation_rendering()
            seg = renderer.render()
            renderer.disable_segmentation_rendering()
        if depth:
            renderer.enable_depth_rendering()
            dist = renderer.render()
            renderer.disable_depth_rendering()
            missed = seg[..., 0] < 0 if seg is not None else dist >= self.far * (1 - 1e-6)
            dist[missed] = 0.0
        return Rendered(colour, dist, seg)

    def close(self) -> None:
        """Free the GL context."""
        _OPEN.discard(self)
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
