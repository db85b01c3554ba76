"""Offscreen rendering of a MuJoCo scene from an arbitrary pinhole camera pose."""

from __future__ import annotations

import atexit
import math
import weakref

import mujoco
import numpy as np
from numpy.typing import NDArray

from simbridge.sim.sensors.frames import Pose
from simbridge.sim.sensors.gl_backend import GLContext, create_gl_context

__all__ = ["OffscreenRenderer"]

_OPEN: weakref.WeakSet[OffscreenRenderer] = weakref.WeakSet()
"""Renderers not closed yet."""


@atexit.register
def _close_at_exit() -> None:
    """Free the GL contexts of renderers nobody closed (an `rgb_array` env left open) while
    the interpreter still runs: MuJoCo's GLContext.__del__ would try during shutdown, when
    PyOpenGL can no longer convert its arguments, and print a ctypes traceback."""
    for renderer in list(_OPEN):
        renderer.close()


class OffscreenRenderer:
    """Renders RGB or metric depth images for a camera at any pose (not a model camera).

    The camera looks along its frame's +x with +z up (ROS body axes); `fovy` is the
    vertical field of view. Pixels are square and the principal point is the image
    centre. Shadows, reflections and multisample anti-aliasing are off unless asked for:
    on a CPU (OSMesa/llvmpipe) 4x MSAA alone makes a frame about four times slower.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        width: int,
        height: int,
        *,
        shadows: bool = False,
        reflections: bool = False,
        multisamples: int = 0,
        max_geom: int = 10000,
    ) -> None:
        # The offscreen framebuffer is sized from the model; grow it when too small.
        model.vis.global_.offwidth = max(int(model.vis.global_.offwidth), width)
        model.vis.global_.offheight = max(int(model.vis.global_.offheight), height)
        self.width = width
        self.height = height
        self._model = model
        self._context: GLContext | None = create_gl_context(width, height)
        _OPEN.add(self)
        self._context.make_current()
        # The context reads the sample count from the model; leave the model as it was.
        model_samples = int(model.vis.quality.offsamples)
        model.vis.quality.offsamples = multisamples
        try:
            self._mjr: mujoco.MjrContext | None = mujoco.MjrContext(
                model, mujoco.mjtFontScale.mjFONTSCALE_100
            )
        finally:
            model.vis.quality.offsamples = model_samples
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, self._mjr)
        self._mjr.readDepthMap = mujoco.mjtDepthMap.mjDEPTH_ZEROFAR
        self._scene = mujoco.MjvScene(model, maxgeom=max_geom)
        self._scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = shadows
        self._scene.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = reflections
        self._option = mujoco.MjvOption()
        self._camera = mujoco.MjvCamera()
        mujoco.mjv_defaultFreeCamera(model, self._camera)
        self._rect = mujoco.MjrRect(0, 0, width, height)
        self._rgb = np.empty((height, width, 3), dtype=np.uint8)
        self._depth = np.empty((height, width), dtype=np.float32)
        self._segments: NDArray[np.uint8] | None = None

    def _prepare(
        self, data: mujoco.MjData, pose: Pose, fovy: float, near: float, far: float
    ) -> None:
        assert self._context is not None, "renderer used after close()"
        self._context.make_current()
        mujoco.mjv_updateScene(
            self._model,
            data,
            self._option,
            None,
            self._camera,
            mujoco.mjtCatBit.mjCAT_ALL,
            self._scene,
        )
        half_height = near * math.tan(fovy / 2)
        for glcam in self._scene.camera:
            glcam.pos[:] = pose.position
            glcam.forward[:] = pose.rotation[:, 0]
            glcam.up[:] = pose.rotation[:, 2]
            glcam.frustum_near = near
            glcam.frustum_far = far
            glcam.frustum_top = half_height
            glcam.frustum_bottom = -half_height
            glcam.frustum_center = 0.0
            glcam.orthographic = 0

    def render_rgb(
        self, data: mujoco.MjData, pose: Pose, fovy: float, near: float, far: float
    ) -> NDArray[np.uint8]:
        """An (height, width, 3) rgb8 image, row 0 at the top."""
        self._prepare(data, pose, fovy, near, far)
        mujoco.mjr_render(self._rect, self._scene, self._mjr)
        mujoco.mjr_readPixels(self._rgb, None, self._rect, self._mjr)
        return np.flipud(self._rgb).copy()

    def _render_id_colours(self) -> None:
        """Render each geom in the flat colour of its segment id (MuJoCo's segmentation
        mode), then restore the scene's flags."""
        flags = self._scene.flags
        flags[mujoco.mjtRndFlag.mjRND_SEGMENT] = True
        flags[mujoco.mjtRndFlag.mjRND_IDCOLOR] = True
        try:
            mujoco.mjr_render(self._rect, self._scene, self._mjr)
        finally:
            flags[mujoco.mjtRndFlag.mjRND_SEGMENT] = False
            flags[mujoco.mjtRndFlag.mjRND_IDCOLOR] = False

    def render_depth(
        self, data: mujoco.MjData, pose: Pose, fovy: float, near: float, far: float
    ) -> NDArray[np.float64]:
        """An (height, width) image of z-depth in metres; +inf where nothing was hit
        between the near and far planes."""
        self._prepare(data, pose, fovy, near, far)
        self._render_id_colours()  # no lighting or skybox: faster, and the depth is exact
        mujoco.mjr_readPixels(None, self._depth, self._rect, self._mjr)
        return _linear_depth(np.flipud(self._depth), near, far)

    def render_segmentation(
        self, data: mujoco.MjData, pose: Pose, fovy: float, near: float, far: float
    ) -> NDArray[np.int32]:
        """An (height, width, 2) image of MuJoCo object id and object type per pixel
        (what `mujoco.Renderer`'s segmentation mode gives), (-1, -1) where nothing was
        drawn. Exact with multisampling too: MuJoCo draws segmentation without it."""
        segments, objects = self.render_segments(data, pose, fovy, near, far)
        out: NDArray[np.int32] = objects[segments]
        return out

    def render_segments(
        self, data: mujoco.MjData, pose: Pose, fovy: float, near: float, far: float
    ) -> tuple[NDArray[np.uint32], NDArray[np.int32]]:
        """The segmentation in two parts: an (height, width) image of segment numbers and
        a (segments, 2) table of each one's object id and type (row 0: nothing drawn).
        Labels look the few segments up and index the image once, which is much faster
        than going through `render_segmentation`'s full-size (id, type) image. The image
        is a view of the renderer's buffer: the next render overwrites it."""
        self._prepare(data, pose, fovy, near, far)
        self._render_id_colours()
        mujoco.mjr_readPixels(self._rgb, None, self._rect, self._mjr)
        # IDCOLOR paints scene geom i (its segid) in the 24-bit colour i + 1 (0: nothing):
        # the colour bytes with a zero fourth byte read as one little-endian uint32.
        if self._segments is None:
            self._segments = np.zeros((self.height, self.width, 4), dtype=np.uint8)
        self._segments[..., :3] = self._rgb
        segments = np.flipud(self._segments.view("<u4")[..., 0])
        scene = self._scene
        objects = np.full((scene.ngeom + 2, 2), -1, dtype=np.int32)
        for index in range(scene.ngeom):
            geom = scene.geoms[index]
            if geom.segid >= 0:
                objects[geom.segid + 1] = (geom.objid, geom.objtype)
        # Any colour no geom has (none expected) reads as the last row: nothing drawn.
        np.minimum(segments, scene.ngeom + 1, out=segments)
        return segments, objects

    def close(self) -> None:
        """Free the GL resources; the renderer cannot be used afterwards."""
        _OPEN.discard(self)
        if self._context is not None:
            self._context.make_current()
            if self._mjr is not None:
                self._mjr.free()
            self._context.free()
        self._mjr = None
        self._context = None


def _linear_depth(buffer: NDArray[np.float32], near: float, far: float) -> NDArray[np.float64]:
    """Undo MuJoCo's reversed-Z perspective depth (1 at near, 0 at far) into metres."""
    zfar, znear = np.float32(far), np.float32(near)
    c_coef = -(zfar + znear) / (zfar - znear)
    d_coef = -(np.float32(2) * zfar * znear) / (zfar - znear)
    c_rev = np.float32(-0.5) * c_coef - np.float32(0.5)
    d_rev = np.float32(-0.5) * d_coef
    depth = float(d_rev) / (buffer.astype(np.float64) + float(c_rev))
    return np.where(buffer <= 0.0, np.inf, depth)
