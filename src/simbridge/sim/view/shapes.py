"""The visual geometry of a MuJoCo model as plain shapes a 3D view can draw.

Each visible geom (groups 0-2: scene objects and URDF visuals; collision geometry, group
3, stays hidden as in MuJoCo's viewer) becomes a `Shape` in its body's frame: a
primitive with its size, or a triangle mesh, with its colour (material colour first).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import mujoco
import numpy as np
import trimesh

__all__ = ["PLANE_EXTENT", "Shape", "ShapeKind", "body_names", "visual_shapes"]

ShapeKind = Literal["box", "sphere", "cylinder", "mesh"]

VISIBLE_GROUPS = frozenset({0, 1, 2})
"""Geom groups drawn (MuJoCo's viewer default); group 3 is simbridge's collision geometry."""
PLANE_EXTENT = 10.0
"""Half size (m) drawn for an infinite plane."""


@dataclass(frozen=True)
class Shape:
    """One geom to draw, posed relative to its body."""

    name: str
    body: int
    kind: ShapeKind
    size: tuple[float, ...]
    """box: full dimensions xyz; sphere: (radius,); cylinder: (radius, height); mesh: ()."""
    rgba: tuple[float, float, float, float]
    position: tuple[float, float, float]
    wxyz: tuple[float, float, float, float]
    vertices: np.ndarray | None = None
    faces: np.ndarray | None = None

    @property
    def rgb255(self) -> tuple[int, int, int]:
        """The colour as 0-255 integers."""
        r, g, b, _ = self.rgba
        return (round(r * 255), round(g * 255), round(b * 255))


def body_names(model: mujoco.MjModel) -> list[str]:
    """Body names by id ("body<id>" for unnamed ones)."""
    return [model.body(i).name or f"body{i}" for i in range(model.nbody)]


def _rgba(model: mujoco.MjModel, geom: int) -> tuple[float, float, float, float]:
    mat = int(model.geom_matid[geom])
    rgba = model.mat_rgba[mat] if mat >= 0 else model.geom_rgba[geom]
    return (float(rgba[0]), float(rgba[1]), float(rgba[2]), float(rgba[3]))


def _arrays(vertices: object, faces: object) -> tuple[np.ndarray, np.ndarray]:
    return np.asarray(vertices, dtype=np.float32), np.asarray(faces, dtype=np.int32)


def visual_shapes(model: mujoco.MjModel) -> list[Shape]:
    """Every visible geom of `model` as a Shape (heightfields are skipped)."""
    shapes: list[Shape] = []
    for g in range(model.ngeom):
        rgba = _rgba(model, g)
        if int(model.geom_group[g]) not in VISIBLE_GROUPS or rgba[3] <= 0.0:
            continue
        kind_id = int(model.geom_type[g])
        size = [float(v) for v in model.geom_size[g]]
        px, py, pz = (float(v) for v in model.geom_pos[g])
        qw, qx, qy, qz = (float(v) for v in model.geom_quat[g])
        pos, quat = (px, py, pz), (qw, qx, qy, qz)
        name = model.geom(g).name or f"geom{g}"
        body = int(model.geom_bodyid[g])

        def add(
            kind: ShapeKind,
            dims: tuple[float, ...] = (),
            mesh: tuple[np.ndarray, np.ndarray] | None = None,
        ) -> None:
            vertices, faces = mesh if mesh is not None else (None, None)
            shapes.append(Shape(name, body, kind, dims, rgba, pos, quat, vertices, faces))  # noqa: B023 - called at once

        geom_type = mujoco.mjtGeom
        if kind_id == geom_type.mjGEOM_BOX:
            add("box", (2 * size[0], 2 * size[1], 2 * size[2]))
        elif kind_id == geom_type.mjGEOM_PLANE:
            add("box", (2 * (size[0] or PLANE_EXTENT), 2 * (size[1] or PLANE_EXTENT), 1e-3))
        elif kind_id == geom_type.mjGEOM_SPHERE:
            add("sphere", (size[0],))
        elif kind_id == geom_type.mjGEOM_CYLINDER:
            add("cylinder", (size[0], 2 * size[1]))
        elif kind_id == geom_type.mjGEOM_CAPSULE:
            tm = trimesh.creation.capsule(height=2 * size[1], radius=size[0], count=[16, 16])
            add("mesh", mesh=_arrays(tm.vertices, tm.faces))
        elif kind_id == geom_type.mjGEOM_ELLIPSOID:
            tm = trimesh.creation.icosphere(subdivisions=3)
            add("mesh", mesh=_arrays(np.asarray(tm.vertices) * size, tm.faces))
        elif kind_id == geom_type.mjGEOM_MESH:
            m = int(model.geom_dataid[g])
            v0, nv = int(model.mesh_vertadr[m]), int(model.mesh_vertnum[m])
            f0, nf = int(model.mesh_faceadr[m]), int(model.mesh_facenum[m])
            add("mesh", mesh=_arrays(model.mesh_vert[v0 : v0 + nv], model.mesh_face[f0 : f0 + nf]))
    return shapes
