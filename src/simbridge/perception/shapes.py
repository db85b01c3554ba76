"""What a geom looks like from a camera: the points whose projections bound its silhouette
(exact for boxes, spheres, capsules, ellipsoids; 64 points a rim for cylinders; the convex
hull's vertices for meshes), in outline order where that is known without a hull (boxes,
cylinders, round rings), and its bounding box in its own frame.

Geoms are read from the model each time (type, size, mesh), so distractor slots whose shape
changes per frame are measured as they are drawn.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
from numpy.typing import NDArray
from scipy.spatial import ConvexHull, QhullError

from simbridge.perception.loops import BOX_CORNERS, RIM, RIM_CIRCLE, box_loop, prism_loop

__all__ = ["Outline", "ShapeCache", "geom_extent", "silhouette_points"]

FloatArray = NDArray[np.float64]

_T = mujoco.mjtGeom
_BOX, _SPHERE, _CAPSULE = int(_T.mjGEOM_BOX), int(_T.mjGEOM_SPHERE), int(_T.mjGEOM_CAPSULE)
_ELLIPSOID, _CYLINDER, _MESH = (
    int(_T.mjGEOM_ELLIPSOID),
    int(_T.mjGEOM_CYLINDER),
    int(_T.mjGEOM_MESH),
)
_PLANE = int(_T.mjGEOM_PLANE)

_EVERY = np.arange(RIM, dtype=np.intp)
"""A round silhouette's ring, in order."""


def _f(values: object) -> FloatArray:
    return np.asarray(values, dtype=np.float64)


@dataclass(frozen=True)
class Outline:
    """A geom's silhouette points in the camera frame and, where known, which of them
    outline it in order (valid while every point is in front of the camera)."""

    points: FloatArray
    loop: NDArray[np.intp] | None = None


class ShapeCache:
    """Mesh hull vertices, computed once per mesh."""

    def __init__(self, model: mujoco.MjModel) -> None:
        self.model = model
        self._hulls: dict[int, FloatArray] = {}

    def mesh_points(self, mesh: int) -> FloatArray:
        """The vertices of mesh `mesh`'s convex hull, in its geom's frame."""
        points = self._hulls.get(mesh)
        if points is None:
            start, count = int(self.model.mesh_vertadr[mesh]), int(self.model.mesh_vertnum[mesh])
            vertices = np.asarray(self.model.mesh_vert[start : start + count], dtype=float)
            try:
                points = vertices[ConvexHull(vertices).vertices]
            except (QhullError, ValueError):  # flat or degenerate: every vertex
                points = vertices
            self._hulls[mesh] = points
        return points


def _tangent_circle(centre: FloatArray, radius: float) -> FloatArray | None:
    """Points of the circle where rays from the origin touch a sphere (camera frame);
    None when the origin is inside the sphere."""
    distance2 = float(centre @ centre)
    if distance2 <= radius * radius:
        return None
    axis = centre / np.sqrt(distance2)
    ring_centre = centre * (1.0 - radius * radius / distance2)
    ring_radius = radius * np.sqrt(1.0 - radius * radius / distance2)
    helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(axis, helper)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    return _f(
        ring_centre
        + ring_radius * (np.outer(RIM_CIRCLE[:, 0], e1) + np.outer(RIM_CIRCLE[:, 1], e2))
    )


def silhouette_points(
    shapes: ShapeCache, geom: int, rotation: FloatArray, position: FloatArray
) -> Outline | None:
    """Camera-frame points whose projections' convex hull is the geom's silhouette;
    `rotation`/`position` are the geom's pose in the camera frame. None for planes (no
    finite silhouette) and for a camera inside a round geom."""
    model = shapes.model
    kind = int(model.geom_type[geom])
    size = np.asarray(model.geom_size[geom], dtype=float)
    camera = -(rotation.T @ position)  # the camera in the geom's frame
    if kind == _BOX:
        return Outline(_f(position + (BOX_CORNERS * size) @ rotation.T), box_loop(camera, size))
    if kind == _SPHERE:
        ring = _tangent_circle(position, float(size[0]))
        return None if ring is None else Outline(ring, _EVERY)
    if kind == _CAPSULE:
        axis = rotation[:, 2] * size[1]
        ends = [_tangent_circle(position + s * axis, float(size[0])) for s in (-1.0, 1.0)]
        if ends[0] is None or ends[1] is None:
            return None
        return Outline(np.vstack([ends[0], ends[1]]))
    if kind == _ELLIPSOID:
        # Scale space so the ellipsoid is a unit sphere, take its tangent circle, scale back.
        camera_local = camera / size
        ring = _tangent_circle(-camera_local, 1.0)
        if ring is None:
            return None
        return Outline(_f(position + ((ring + camera_local) * size) @ rotation.T), _EVERY)
    if kind == _CYLINDER:
        rim = RIM_CIRCLE * size[0]
        local = np.vstack(
            [rim - np.array([0.0, 0.0, size[1]]), rim + np.array([0.0, 0.0, size[1]])]
        )
        loop = prism_loop(camera, float(size[0]), float(size[1]))
        return Outline(_f(position + local @ rotation.T), loop)
    if kind == _MESH:
        mesh = shapes.mesh_points(int(model.geom_dataid[geom]))
        return Outline(_f(position + mesh @ rotation.T))
    return None


def geom_extent(shapes: ShapeCache, geom: int) -> FloatArray | None:
    """The 8 corners of the geom's bounding box in its own frame; None for planes."""
    model = shapes.model
    kind = int(model.geom_type[geom])
    size = np.asarray(model.geom_size[geom], dtype=float)
    if kind == _PLANE:
        return None
    if kind == _MESH:
        points = shapes.mesh_points(int(model.geom_dataid[geom]))
        low, high = points.min(axis=0), points.max(axis=0)
        return _f((low + high) / 2 + BOX_CORNERS * (high - low) / 2)
    half = {
        _BOX: size,
        _SPHERE: np.full(3, size[0]),
        _ELLIPSOID: size,
        _CAPSULE: np.array([size[0], size[0], size[0] + size[1]]),
        _CYLINDER: np.array([size[0], size[0], size[1]]),
    }.get(kind)
    if half is None:  # heightfields, SDFs: their model bounding box
        centre = np.asarray(model.geom_aabb[geom][:3], dtype=float)
        return _f(centre + BOX_CORNERS * np.asarray(model.geom_aabb[geom][3:], dtype=float))
    return _f(BOX_CORNERS * half)
