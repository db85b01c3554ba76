"""Amodal silhouettes: camera-frame points cut at the near plane, projected, wrapped in a
convex hull (or taken in their outline's order, when the geom knows it and is wholly in
front of the camera), filled at pixel centres (as OpenGL rasterises) and measured against
the image.

An instance's amodal silhouette is the union of its geoms' hulls: exact for convex geoms
(boxes, spheres, cylinders, capsules, ellipsoids, convex meshes), an upper bound for
non-convex meshes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import ConvexHull, QhullError

from simbridge.perception.camera import CameraView
from simbridge.perception.shapes import Outline

__all__ = ["Silhouette", "clip_near", "fill_convex", "hull_polygon", "polygon_area", "silhouette"]

FloatArray = NDArray[np.float64]


def clip_near(points: FloatArray, near: float) -> FloatArray:
    """The points in front of z = `near`, plus where segments between points in front and
    points behind cross it: the hull of the result is the hull of `points` cut by the plane."""
    front = points[:, 2] >= near
    if front.all():
        return points
    ahead, behind = points[front], points[~front]
    if not len(ahead):
        return ahead
    p = ahead[:, None, :]
    q = behind[None, :, :]
    t = (near - p[..., 2]) / (q[..., 2] - p[..., 2])
    crossings = (p + t[..., None] * (q - p)).reshape(-1, 3)
    return np.vstack([ahead, crossings])


def hull_polygon(uv: FloatArray) -> FloatArray:
    """The convex hull of 2D points, counter-clockwise (fewer than 3 distinct points, or
    all on a line: their bounding box's outline)."""
    if len(uv) >= 3:
        try:
            hull = ConvexHull(uv)
            return np.asarray(uv[hull.vertices], dtype=np.float64)
        except QhullError:
            pass
    low, high = uv.min(axis=0), uv.max(axis=0)
    return np.array([[low[0], low[1]], [high[0], low[1]], [high[0], high[1]], [low[0], high[1]]])


def polygon_area(polygon: FloatArray) -> float:
    """Shoelace area of a simple polygon."""
    x, y = polygon[:, 0], polygon[:, 1]
    return 0.5 * abs(float(np.dot(x, _next(y)) - np.dot(y, _next(x))))


def _next(values: FloatArray) -> FloatArray:
    """Each vertex's successor around the polygon (np.roll(values, -1), without its cost)."""
    return np.concatenate((values[1:], values[:1]))


def _clip_rect(polygon: FloatArray, low: FloatArray, high: FloatArray) -> FloatArray:
    """Sutherland-Hodgman: a convex polygon cut to the box [low, high]."""
    out = polygon
    for axis in (0, 1):
        for bound, keep_above in ((low[axis], True), (high[axis], False)):
            if not len(out):
                return out
            inside = out[:, axis] >= bound if keep_above else out[:, axis] <= bound
            if inside.all():
                continue
            kept: list[FloatArray] = []
            prev, prev_in = out[-1], bool(inside[-1])
            for point, now_in in zip(out, inside, strict=True):
                if now_in != prev_in:
                    t = (bound - prev[axis]) / (point[axis] - prev[axis])
                    kept.append(prev + t * (point - prev))
                if now_in:
                    kept.append(point)
                prev, prev_in = point, bool(now_in)
            out = np.array(kept) if kept else np.empty((0, 2))
    return out


def fill_convex(polygon: FloatArray, mask: NDArray[np.bool_], origin: tuple[int, int]) -> None:
    """Set the pixels of `mask` whose centres lie in the convex `polygon`; `mask`'s
    element [0, 0] is image pixel (column, row) `origin`."""
    height, width = mask.shape
    u0, v0 = origin
    v_low = max(int(np.ceil(polygon[:, 1].min())), v0)
    v_high = min(int(np.floor(polygon[:, 1].max())), v0 + height - 1)
    if v_low > v_high:
        return
    rows = np.arange(v_low, v_high + 1, dtype=float)[:, None]
    x0, y0 = polygon[:, 0], polygon[:, 1]
    x1, y1 = _next(x0), _next(y0)
    dy = y1 - y0
    crosses = (rows >= np.minimum(y0, y1)) & (rows <= np.maximum(y0, y1)) & (dy != 0)
    xs = x0 + (rows - y0) / np.where(dy != 0, dy, 1.0) * (x1 - x0)
    left = np.ceil(np.where(crosses, xs, np.inf).min(axis=1))
    right = np.floor(np.where(crosses, xs, -np.inf).max(axis=1))
    cols = np.arange(u0, u0 + width, dtype=float)[None, :]
    inside = (cols >= left[:, None]) & (cols <= right[:, None])
    mask[v_low - v0 : v_high - v0 + 1] |= inside


@dataclass
class Silhouette:
    """An instance's projected outline in one camera."""

    polygons: list[FloatArray]
    """One convex polygon (pixel coordinates) per geom seen."""
    box: tuple[float, float, float, float]
    """Amodal box (u_min, v_min, u_max, v_max) of the whole projection."""
    truncation: float
    """Share of the projected area outside the image (0: wholly inside, 1: wholly out)."""

    def mask(self, width: int, height: int) -> tuple[NDArray[np.bool_], tuple[int, int]]:
        """The filled silhouette inside the image: a mask over the amodal box clipped to
        the image, and its top-left pixel (column, row)."""
        u0 = max(int(np.ceil(self.box[0])), 0)
        v0 = max(int(np.ceil(self.box[1])), 0)
        u1 = min(int(np.floor(self.box[2])), width - 1)
        v1 = min(int(np.floor(self.box[3])), height - 1)
        mask = np.zeros((max(v1 - v0 + 1, 0), max(u1 - u0 + 1, 0)), dtype=bool)
        if mask.size:
            for polygon in self.polygons:
                fill_convex(polygon, mask, (u0, v0))
        return mask, (u0, v0)


def silhouette(view: CameraView, outlines: list[Outline], near: float) -> Silhouette | None:
    """The silhouette of an instance from its geoms' camera-frame outlines (None when
    nothing of it is in front of the camera)."""
    polygons = []
    for outline in outlines:
        points = outline.points
        if outline.loop is not None and points[:, 2].min() >= near:
            polygons.append(view.project(points[outline.loop]))
            continue
        ahead = clip_near(points, near)
        if len(ahead):
            polygons.append(hull_polygon(view.project(ahead)))
    if not polygons:
        return None
    stacked = np.vstack(polygons)
    low, high = stacked.min(axis=0), stacked.max(axis=0)
    image_low = np.array([-0.5, -0.5])
    image_high = np.array([view.width - 0.5, view.height - 0.5])
    total = inside = 0.0
    for polygon in polygons:
        total += polygon_area(polygon)
        clipped = _clip_rect(polygon, image_low, image_high)
        inside += polygon_area(clipped) if len(clipped) >= 3 else 0.0
    truncation = 1.0 - inside / total if total > 0 else 0.0
    box = (float(low[0]), float(low[1]), float(high[0]), float(high[1]))
    return Silhouette(polygons, box, min(max(truncation, 0.0), 1.0))
