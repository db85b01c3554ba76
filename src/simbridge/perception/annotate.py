"""Per-view labels from the rendered images and the simulator's state: instance and class
images, tight and amodal 2D boxes, visible fraction, truncation, 3D boxes, 6D poses and
robot keypoints, all in the camera's optical frame (REP 103: x right, y down, z forward).
"""

from __future__ import annotations

from collections.abc import Collection
from dataclasses import dataclass, field

import mujoco
import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from simbridge.perception.bands import lookup
from simbridge.perception.camera import CameraView
from simbridge.perception.render import Rendered
from simbridge.perception.shapes import ShapeCache, geom_extent, silhouette_points
from simbridge.perception.silhouette import Silhouette, silhouette
from simbridge.sim.labels import Instance, LabelTable

__all__ = ["KEYPOINT_DEPTH_TOLERANCE", "Box3D", "InstanceLabel", "ViewLabels", "annotate"]

FloatArray = NDArray[np.float64]
Mask = NDArray[np.bool_]
KEYPOINT_DEPTH_TOLERANCE = 0.01
"""A keypoint this close (m) behind the surface drawn at its pixel still counts as seen."""


@dataclass(frozen=True)
class Box3D:
    """An oriented 3D box in the camera frame: centre (m), full edge lengths (m) and the
    rotation from box axes to camera axes."""

    center: FloatArray
    size: FloatArray
    rotation: FloatArray

    def corners(self) -> FloatArray:
        """The 8 corners (camera frame)."""
        signs = np.array(
            [[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float
        )
        return self.center + (signs * self.size / 2) @ self.rotation.T


@dataclass
class InstanceLabel:
    """One instance seen (or in the frustum but hidden) in one view."""

    instance: Instance
    visible_px: int
    amodal_px: int
    """Pixels of the amodal silhouette inside the image (including the visible ones)."""
    truncation: float
    tight_box: tuple[int, int, int, int] | None
    """(column_min, row_min, column_max, row_max) of the visible pixels, inclusive."""
    amodal_box: tuple[float, float, float, float]
    """(u_min, v_min, u_max, v_max) of the projected geometry (may leave the image)."""
    rotation: FloatArray
    """Instance frame to camera frame (the root body's frame)."""
    translation: FloatArray
    """Instance frame origin in the camera frame (m)."""
    box3d: Box3D | None
    visible_mask: Mask | None = None
    """Over `tight_box` (rows, columns)."""
    amodal_mask: tuple[Mask, tuple[int, int]] | None = None
    """The in-image silhouette mask and its top-left pixel (column, row)."""
    keypoints: FloatArray | None = None
    """(K, 3): u, v and visibility (0 outside the image or behind, 1 hidden, 2 seen)."""

    @property
    def visibility(self) -> float:
        """Visible share of the in-image silhouette."""
        return self.visible_px / self.amodal_px if self.amodal_px else 0.0


@dataclass
class ViewLabels:
    """Everything labelled in one view."""

    view: CameraView
    instance_image: NDArray[np.uint16] | None
    category_image: NDArray[np.uint16] | None
    instances: list[InstanceLabel] = field(default_factory=list)


def _pose(data: mujoco.MjData, body: int, view: CameraView) -> tuple[FloatArray, FloatArray]:
    rotation = view.rotation.T @ data.xmat[body].reshape(3, 3)
    translation = view.rotation.T @ (data.xpos[body] - view.position)
    return rotation, translation


def _box3d(
    shapes: ShapeCache, data: mujoco.MjData, inst: Instance, geoms: list[int], view: CameraView
) -> Box3D | None:
    """Box around the instance's drawn geoms: in the root body's axes for a one-body
    instance, in world axes otherwise."""
    corners = []
    for geom in geoms:
        extent = geom_extent(shapes, geom)
        if extent is not None:
            corners.append(data.geom_xpos[geom] + extent @ data.geom_xmat[geom].reshape(3, 3).T)
    if not corners:
        return None
    world = np.vstack(corners)
    if len(inst.bodies) == 1:
        axes = data.xmat[inst.root_body].reshape(3, 3)
        origin = data.xpos[inst.root_body]
    else:
        axes, origin = np.eye(3), np.zeros(3)
    local = (world - origin) @ axes
    low, high = local.min(axis=0), local.max(axis=0)
    centre_world = origin + axes @ ((low + high) / 2)
    return Box3D(view.world_to_camera(centre_world[None, :])[0], high - low, view.rotation.T @ axes)


def _silhouette(
    shapes: ShapeCache, data: mujoco.MjData, geoms: list[int], view: CameraView, near: float
) -> Silhouette | None:
    outlines = []
    for geom in geoms:
        rotation = view.rotation.T @ data.geom_xmat[geom].reshape(3, 3)
        position = view.rotation.T @ (data.geom_xpos[geom] - view.position)
        outline = silhouette_points(shapes, geom, rotation, position)
        if outline is not None:
            outlines.append(outline)
    return silhouette(view, outlines, near)


def _union_count(
    visible: Mask | None,
    tight: tuple[int, int, int, int] | None,
    amodal: tuple[Mask, tuple[int, int]],
) -> int:
    """Pixels in the amodal mask or the visible mask."""
    mask, (u0, v0) = amodal
    count = int(mask.sum())
    if visible is None or tight is None:
        return count
    rows, cols = np.nonzero(visible)
    rows = rows + tight[1] - v0
    cols = cols + tight[0] - u0
    inside = (rows >= 0) & (rows < mask.shape[0]) & (cols >= 0) & (cols < mask.shape[1])
    covered = np.zeros(len(rows), dtype=bool)
    covered[inside] = mask[rows[inside], cols[inside]]
    return count + int((~covered).sum())


def _keypoints(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    inst: Instance,
    view: CameraView,
    *,
    rendered: Rendered,
    near: float,
) -> FloatArray:
    points = view.world_to_camera(data.xpos[list(inst.bodies)])
    out = np.zeros((len(points), 3))
    ahead = points[:, 2] > near
    if ahead.any():
        out[ahead, :2] = view.project(points[ahead])
    neighbours = {b: {b, int(model.body_parentid[b])} for b in inst.bodies}
    for child in range(model.nbody):
        parent = int(model.body_parentid[child])
        if parent in neighbours:
            neighbours[parent].add(child)
    depth = rendered.depth
    for k, body in enumerate(inst.bodies):
        if not ahead[k]:
            continue
        col, row = round(out[k, 0]), round(out[k, 1])
        if not (0 <= col < view.width and 0 <= row < view.height):
            out[k, :2] = 0.0 if not np.isfinite(out[k, :2]).all() else out[k, :2]
            continue
        seen = False
        if rendered.segments is not None:
            shown, kind = rendered.object_at(row, col)
            if kind == int(mujoco.mjtObj.mjOBJ_GEOM):
                seen = int(model.geom_bodyid[shown]) in neighbours[body]
        if not seen and depth is not None:
            drawn = float(depth[row, col])
            seen = drawn == 0.0 or drawn >= points[k, 2] - KEYPOINT_DEPTH_TOLERANCE
        out[k, 2] = 2.0 if seen else 1.0
    return out


def annotate(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    view: CameraView,
    rendered: Rendered,
    *,
    table: LabelTable,
    shapes: ShapeCache,
    labelers: Collection[str],
    near: float,
) -> ViewLabels:
    """Labels of one rendered view (`labelers` chooses which are computed)."""
    instance_image = category_image = None
    if rendered.segments is not None and rendered.objects is not None:
        # Ids per segment (a few dozen), then one look-up per pixel.
        instance_image = lookup(table.instance_image(rendered.objects), rendered.segments)
        if "semantic" in labelers:
            category_image = lookup(table.category_image(rendered.objects), rendered.segments)
    labels = ViewLabels(view, instance_image, category_image)
    wants_2d = "boxes_2d" in labelers or "instance" in labelers
    if not (wants_2d or "boxes_3d" in labelers or "poses" in labelers or "keypoints" in labelers):
        return labels
    slices = ndimage.find_objects(instance_image) if instance_image is not None else []
    shown = np.asarray(model.geom_group) < 3  # what the renderer draws
    for inst in table.instances:
        geoms = [g for g in inst.geoms if shown[g]]
        if not geoms:
            continue  # a distractor slot unused in this frame
        outline = _silhouette(shapes, data, geoms, view, near)
        found = slices[inst.id - 1] if inst.id - 1 < len(slices) else None
        visible_mask = tight = None
        visible_px = 0
        if found is not None and instance_image is not None:
            visible_mask = instance_image[found] == inst.id
            visible_px = int(visible_mask.sum())
            rows, cols = found
            tight = (cols.start, rows.start, cols.stop - 1, rows.stop - 1)
        if outline is None and visible_px == 0:
            continue
        amodal = outline.mask(view.width, view.height) if outline is not None else None
        amodal_px = _union_count(visible_mask, tight, amodal) if amodal is not None else visible_px
        if amodal_px == 0:
            continue  # wholly outside the image
        rotation, translation = _pose(data, inst.root_body, view)
        if outline is not None:
            amodal_box, truncation = outline.box, outline.truncation
        else:
            assert tight is not None
            amodal_box = (tight[0] - 0.5, tight[1] - 0.5, tight[2] + 0.5, tight[3] + 0.5)
            truncation = 0.0
        label = InstanceLabel(
            inst,
            visible_px,
            amodal_px,
            truncation,
            tight,
            amodal_box,
            rotation,
            translation,
            _box3d(shapes, data, inst, geoms, view) if "boxes_3d" in labelers else None,
            visible_mask,
            amodal,
        )
        if "keypoints" in labelers and inst.kind == "robot":
            label.keypoints = _keypoints(model, data, inst, view, rendered=rendered, near=near)
        labels.instances.append(label)
    return labels
