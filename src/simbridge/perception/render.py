"""RGB, metric depth and segmentation of one camera view, with MuJoCo's classic renderer
in two passes: a lit one for RGB, and one in segment-id colours whose colour and depth
buffers are read together (segmentation and depth from one render)."""

from __future__ import annotations

import atexit
import math
import time
import weakref
from dataclasses import dataclass, field, replace

import mujoco
import numpy as np
from numpy.typing import NDArray

from simbridge.errors import PerceptionError
from simbridge.perception.bands import lookup
from simbridge.perception.camera import CameraView
from simbridge.sim.sensors import configure_gl
from simbridge.sim.sensors.gl_backend import GLContext, create_gl_context

__all__ = ["QUALITIES", "Preset", "RenderSettings", "Rendered", "StageTimes", "ViewRenderer"]

_OPEN: weakref.WeakSet[ViewRenderer] = weakref.WeakSet()

_MAX_GEOM = 10000
"""Scene geoms at most (what `mujoco.Renderer` allows by default)."""


@atexit.register
def _close_at_exit() -> None:
    """Free GL contexts nobody closed while PyOpenGL still works (see sim.sensors.offscreen)."""
    for renderer in list(_OPEN):
        renderer.close()


@dataclass(frozen=True)
class Preset:
    """A render quality: shadows, multisampling and the shadow map's size."""

    shadows: bool
    multisamples: int
    shadow_size: int | None = None
    """Shadow map side in texels (None: the model's, MuJoCo's default 4096)."""


QUALITIES = {
    "high": Preset(shadows=True, multisamples=4),
    "balanced": Preset(shadows=True, multisamples=0, shadow_size=2048),
    "fast": Preset(shadows=False, multisamples=0),
}
"""Render presets. On a CPU (llvmpipe), for a 640x480 frame of the datagen scene, `fast`
renders about 5x faster than `high` and `balanced` (shadows, no anti-aliasing) about 2x;
labels are the same at every quality."""


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
    shadow_size: int | None = None
    """Shadow map side in texels (None: the model's; smaller is faster and blurrier)."""

    def with_quality(self, quality: str) -> RenderSettings:
        """These settings with a preset's shadows, multisampling and shadow map size
        (QUALITIES)."""
        if quality not in QUALITIES:
            raise PerceptionError(
                f"render quality {quality!r} unknown (valid: {', '.join(QUALITIES)})"
            )
        preset = QUALITIES[quality]
        return replace(
            self,
            shadows=preset.shadows,
            multisamples=preset.multisamples,
            shadow_size=preset.shadow_size,
        )


@dataclass
class Rendered:
    """One view's images (None where not asked for)."""

    rgb: NDArray[np.uint8] | None
    depth: NDArray[np.float32] | None
    """z distance along the optical axis (m); 0 where nothing was hit."""
    segments: NDArray[np.uint32] | None
    """(H, W) segment number per pixel, a row of `objects` (0: nothing drawn)."""
    objects: NDArray[np.int32] | None
    """(segments, 2): each segment's MuJoCo object id and object type; (-1, -1) for
    nothing drawn. Labels look the few segments up, then index the image once."""
    empty: NDArray[np.bool_] | None = None
    """Where no geometry was drawn (the sky), if the segmentation was rendered."""

    def object_at(self, row: int, col: int) -> tuple[int, int]:
        """(object id, object type) drawn at one pixel; (-1, -1) for nothing."""
        if self.segments is None or self.objects is None:
            raise PerceptionError("render: the segmentation was not rendered")
        found = self.objects[self.segments[row, col]]
        return int(found[0]), int(found[1])


@dataclass
class StageTimes:
    """CPU seconds of the process (llvmpipe's threads included) a renderer spent per stage
    since it was made, and the views it rendered: where a frame's time goes, robust to
    other processes' load (not to other threads of this one)."""

    seconds: dict[str, float] = field(default_factory=dict)
    views: int = 0

    def add(self, stage: str, since: float) -> float:
        """Charge the process CPU time since `since` to `stage`; the time now."""
        now = time.process_time()
        self.seconds[stage] = self.seconds.get(stage, 0.0) + now - since
        return now


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
        if settings.shadow_size is not None:
            model.vis.quality.shadowsize = settings.shadow_size
        model.vis.global_.offwidth = max(int(model.vis.global_.offwidth), width)
        model.vis.global_.offheight = max(int(model.vis.global_.offheight), height)
        self.width, self.height = width, height
        self.settings = settings
        self.times = StageTimes()
        # The planes depth is linearised with (what mujoco.Renderer uses).
        self.near = float(model.vis.map.znear) * extent
        self.far = float(model.vis.map.zfar) * extent
        self._model = model
        self._context: GLContext | None = create_gl_context(width, height)
        _OPEN.add(self)
        self._context.make_current()
        self._mjr: mujoco.MjrContext | None = mujoco.MjrContext(
            model, mujoco.mjtFontScale.mjFONTSCALE_150
        )
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, self._mjr)
        self._mjr.readDepthMap = mujoco.mjtDepthMap.mjDEPTH_ZEROFAR
        self._rect = mujoco.MjrRect(0, 0, width, height)
        self._scene = mujoco.MjvScene(model, maxgeom=_MAX_GEOM)
        self._scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = settings.shadows
        self._scene.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = settings.reflections
        self._option = mujoco.MjvOption()
        self._option.sitegroup[:] = 0  # sites are markers, not things a camera sees
        self._camera = mujoco.MjvCamera()
        mujoco.mjv_defaultFreeCamera(model, self._camera)
        self._colour = np.empty((height, width, 3), dtype=np.uint8)
        self._ids = np.empty((height, width, 3), dtype=np.uint8)
        self._zbuffer = np.empty((height, width), dtype=np.float32)

    def render(
        self, data: mujoco.MjData, view: CameraView, *, rgb: bool, depth: bool, segmentation: bool
    ) -> Rendered:
        """The images asked for, of `data` seen from `view`: at most two renders (RGB; one
        in segment colours giving segmentation and depth together)."""
        if self._context is None or self._mjr is None:
            raise PerceptionError("render: the renderer was closed")
        clock = time.process_time()
        self._context.make_current()
        scene = self._scene
        # MuJoCo lays out infinite planes (and the headlight) around the scene's camera,
        # partly the one of the previous frame: set ours before and after the update, and
        # aim the free camera the same way, so a frame never depends on the one before.
        for glcam in scene.camera:
            view.apply_to(glcam, self.near, self.far)
        forward = view.rotation[:, 2]
        self._camera.lookat[:] = view.position + forward
        self._camera.distance = 1.0
        self._camera.azimuth = math.degrees(math.atan2(forward[1], forward[0]))
        self._camera.elevation = math.degrees(math.asin(max(-1.0, min(1.0, float(forward[2])))))
        mujoco.mjv_updateScene(
            self._model,
            data,
            self._option,
            None,
            self._camera,
            mujoco.mjtCatBit.mjCAT_ALL,
            scene,
        )
        for glcam in scene.camera:
            view.apply_to(glcam, self.near, self.far)
        clock = self.times.add("scene update", clock)
        colour = segments = objects = dist = empty = None
        if rgb:
            mujoco.mjr_render(self._rect, scene, self._mjr)
            clock = self.times.add("RGB render", clock)
            mujoco.mjr_readPixels(self._colour, None, self._rect, self._mjr)
            colour = np.flipud(self._colour).copy()  # GL rows run bottom-up
            clock = self.times.add("RGB readPixels", clock)
        if segmentation or depth:
            self._render_id_colours()
            clock = self.times.add("ID render", clock)
            zbuffer = self._zbuffer if depth else None
            mujoco.mjr_readPixels(self._ids, zbuffer, self._rect, self._mjr)
            clock = self.times.add("ID+depth readPixels", clock)
            segments, objects = self._segments()
            empty = lookup(objects[:, 0] < 0, segments)
            if depth:
                dist = self._metric_depth()
                np.copyto(dist, np.float32(0.0), where=empty)
            if not segmentation:
                segments = objects = empty = None
            clock = self.times.add("decode segmentation and depth", clock)
        self.times.views += 1
        return Rendered(colour, dist, segments, objects, empty)

    def _render_id_colours(self) -> None:
        """Render each geom in the flat colour of its segment id, as `mujoco.Renderer`'s
        segmentation and depth modes do, then restore the scene's flags."""
        flags = self._scene.flags
        original = flags.copy()
        flags[mujoco.mjtRndFlag.mjRND_SEGMENT] = True
        flags[mujoco.mjtRndFlag.mjRND_IDCOLOR] = True
        try:
            mujoco.mjr_render(self._rect, self._scene, self._mjr)
        finally:
            np.copyto(flags, original)

    def _segments(self) -> tuple[NDArray[np.uint32], NDArray[np.int32]]:
        """The segment image (top row first) and each segment's (object id, type): IDCOLOR
        paints scene geom i (its segid) in the 24-bit colour i + 1 (0: nothing), so the
        colour bytes with a zero fourth byte read as one little-endian uint32."""
        quads = np.zeros((self.height, self.width, 4), dtype=np.uint8)
        quads[::-1, :, :3] = self._ids  # GL rows run bottom-up
        segments: NDArray[np.uint32] = quads.view("<u4")[..., 0]
        scene = self._scene
        objects = np.full((scene.ngeom + 2, 2), -1, dtype=np.int32)
        for index in range(scene.ngeom):
            geom = scene.geoms[index]
            if geom.segid >= 0:
                objects[geom.segid + 1] = (geom.objid, geom.objtype)
        # Any colour no geom has (none expected) reads as the last row: nothing drawn.
        np.minimum(segments, scene.ngeom + 1, out=segments)
        return segments, objects

    def _metric_depth(self) -> NDArray[np.float32]:
        """z depth in metres from the reversed-Z buffer, in `mujoco.Renderer`'s arithmetic
        (float32 coefficients, float64 division, float32 result)."""
        zfar, znear = np.float32(self.far), np.float32(self.near)
        c_coef = -(zfar + znear) / (zfar - znear)
        d_coef = -(np.float32(2) * zfar * znear) / (zfar - znear)
        c_coef = np.float32(-0.5) * c_coef - np.float32(0.5)
        d_coef = np.float32(-0.5) * d_coef
        metres = self._zbuffer[::-1].astype(np.float64)  # GL rows run bottom-up
        metres += c_coef
        np.divide(d_coef, metres, out=metres)
        return metres.astype(np.float32)

    def close(self) -> None:
        """Free the GL context."""
        _OPEN.discard(self)
        if self._context is not None:
            self._context.make_current()
            if self._mjr is not None:
                self._mjr.free()
            self._context.free()
        self._mjr = None
        self._context = None
