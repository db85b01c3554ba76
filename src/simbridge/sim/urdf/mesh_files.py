"""Read mesh files the way ROS tools mean them: STL (binary or ASCII), COLLADA with its
`<unit>` (and, if asked, `<up_axis>`), OBJ/PLY/GLB, keeping colours and textures per part."""

from __future__ import annotations

import re
import struct
from dataclasses import dataclass
from pathlib import Path

import collada
import numpy as np
import trimesh
from numpy.typing import NDArray

from simbridge.errors import UrdfError

__all__ = [
    "MUJOCO_STL_FACES",
    "Appearance",
    "ColouredMesh",
    "collada_frame",
    "read_mesh",
    "simplify",
    "stl_kind",
]

MUJOCO_STL_FACES = 200_000
"""MuJoCo refuses STL files with more faces than this; simbridge keeps every mesh below it."""
_MAX_COLOUR_PARTS = 16


@dataclass(frozen=True)
class Appearance:
    """How a part of a mesh looks: a colour (RGBA 0..1) and optionally a diffuse texture."""

    rgba: tuple[float, float, float, float] | None = None
    texture: object | None = None
    """A PIL image, drawn with the part's UV coordinates."""


@dataclass(frozen=True)
class ColouredMesh:
    """One part of a mesh file (in metres, Z up) and its appearance."""

    mesh: trimesh.Trimesh
    look: Appearance


def stl_kind(path: Path) -> tuple[str, int]:
    """("binary" | "ascii", face count) of an STL file; a truncated binary file is an error."""
    data = path.read_bytes()
    if len(data) >= 84:
        count = struct.unpack_from("<I", data, 80)[0]
        if len(data) == 84 + 50 * count and count > 0:
            return "binary", count
    head = data[:512].lstrip().lower()
    if head.startswith(b"solid") and b"facet" in data[:4096].lower():
        return "ascii", data.lower().count(b"facet normal")
    if len(data) < 84:
        raise UrdfError(f"mesh '{path}': {len(data)} bytes is too short for an STL file")
    count = struct.unpack_from("<I", data, 80)[0]
    raise UrdfError(
        f"mesh '{path}': binary STL is truncated or corrupt: its header says {count} "
        f"triangles ({84 + 50 * count} bytes), the file has {len(data)} bytes; "
        "re-export the mesh"
    )


def collada_frame(path: Path) -> tuple[float, str]:
    """(metres per unit, up axis) from a COLLADA file's `<asset>` (defaults: 1, Y_UP)."""
    head = path.read_bytes()[:65536].decode("utf-8", "replace")
    asset = re.search(r"<asset>(.*?)</asset>", head, re.DOTALL)
    text = asset.group(1) if asset else ""
    unit = re.search(r"<unit\b[^>]*\bmeter\s*=\s*\"([^\"]+)\"", text)
    up = re.search(r"<up_axis>\s*(\w+)\s*</up_axis>", text)
    try:
        meter = float(unit.group(1)) if unit else 1.0
    except ValueError:
        raise UrdfError(
            f"mesh '{path}': <unit meter='{unit.group(1) if unit else ''}'> is not a number"
        ) from None
    if not meter > 0:
        raise UrdfError(f"mesh '{path}': <unit meter='{meter}'> must be positive")
    return meter, up.group(1) if up else "Y_UP"


_UP_TO_Z = {
    "Z_UP": np.eye(4),
    "Y_UP": np.array([[1, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1]], dtype=float),
    "X_UP": np.array([[0, 0, -1, 0], [0, 1, 0, 0], [1, 0, 0, 0], [0, 0, 0, 1]], dtype=float),
}


def _rgba(colour: object) -> tuple[float, float, float, float] | None:
    if colour is None:
        return None
    values = np.asarray(colour, dtype=np.float64).ravel()
    if values.size < 3:
        return None
    if values.max() > 1.0:
        values = values / 255.0
    r, g, b = (float(v) for v in values[:3])
    a = float(values[3]) if values.size > 3 else 1.0
    return (r, g, b, a)


def _parts_of(mesh: trimesh.Trimesh) -> list[ColouredMesh]:
    """Split one loaded mesh by how it looks: texture, material colour or vertex colours."""
    visual = mesh.visual
    kind = getattr(visual, "kind", None)
    if kind == "texture":
        material = getattr(visual, "material", None)
        image = getattr(material, "image", None) or getattr(material, "baseColorTexture", None)
        uv = getattr(visual, "uv", None)
        colour = _rgba(getattr(material, "main_color", None))
        if image is not None and uv is not None and len(uv) == len(mesh.vertices):
            return [
                ColouredMesh(mesh, Appearance((1.0, 1.0, 1.0, colour[3] if colour else 1.0), image))
            ]
        return [ColouredMesh(mesh, Appearance(colour))]
    if kind in ("vertex", "face") and isinstance(visual, trimesh.visual.ColorVisuals):
        face_colours = np.asarray(visual.face_colors, dtype=np.float64)[:, :4] / 255.0
        return _split_by_colour(mesh, face_colours)
    return [ColouredMesh(mesh, Appearance(None))]


def _split_by_colour(mesh: trimesh.Trimesh, colours: NDArray[np.float64]) -> list[ColouredMesh]:
    """Group faces by colour (quantised; at most `_MAX_COLOUR_PARTS` groups, the rarest
    colours joining their nearest kept one)."""
    quantised = np.round(colours * 31) / 31
    unique, inverse, counts = np.unique(quantised, axis=0, return_inverse=True, return_counts=True)
    inverse = inverse.ravel()
    keep = np.argsort(-counts)[:_MAX_COLOUR_PARTS]
    nearest = np.argmin(((unique[:, None, :] - unique[keep][None, :, :]) ** 2).sum(axis=2), axis=1)
    group = keep[nearest][inverse]
    parts = []
    for g in np.unique(group):
        faces = np.nonzero(group == g)[0]
        sub = mesh.submesh([faces], append=True, repair=False)
        assert isinstance(sub, trimesh.Trimesh)
        r, gr, b, a = (float(v) for v in unique[g])
        parts.append(ColouredMesh(sub, Appearance((r, gr, b, a))))
    return parts


def _load_collada_geometry(path: Path) -> trimesh.Trimesh | None:
    """Every triangle of a COLLADA file's geometry library, ignoring its (broken) scene;
    for files whose scene references missing materials, which trimesh then drops."""
    ignore = [collada.common.DaeUnsupportedError, collada.common.DaeBrokenRefError]
    doc = collada.Collada(str(path), ignore=ignore)
    pieces = []
    for geometry in doc.geometries:
        for primitive in geometry.primitives:
            triangles = primitive.triangleset() if hasattr(primitive, "triangleset") else primitive
            if not hasattr(triangles, "vertex_index") or triangles.vertex_index is None:
                continue
            pieces.append(
                trimesh.Trimesh(np.asarray(triangles.vertex), np.asarray(triangles.vertex_index))
            )
    if not pieces:
        return None
    merged = trimesh.util.concatenate(pieces)
    return merged if isinstance(merged, trimesh.Trimesh) else None


def _collada_vertex_coloured(path: Path) -> list[ColouredMesh]:
    """The parts of a COLLADA file with per-vertex COLOR inputs (which trimesh drops), split
    by face colour; primitives without colours take their material's diffuse colour."""
    ignore = [collada.common.DaeUnsupportedError, collada.common.DaeBrokenRefError]
    doc = collada.Collada(str(path), ignore=ignore)
    parts: list[ColouredMesh] = []
    bound = list(doc.scene.objects("geometry")) if doc.scene is not None else []
    for geometry in bound:
        for primitive in geometry.primitives():
            tris = primitive.triangleset() if hasattr(primitive, "triangleset") else primitive
            if getattr(tris, "vertex_index", None) is None or not len(tris.vertex_index):
                continue
            mesh = trimesh.Trimesh(
                np.asarray(tris.vertex), np.asarray(tris.vertex_index), process=False
            )
            original = tris.original
            inputs = original.sources.get("COLOR") or []
            if inputs:
                offset, source = inputs[0][0], inputs[0][4]
                data = np.asarray(source.data, dtype=np.float64).reshape(len(source.data), -1)
                if data.shape[1] == 3:
                    data = np.hstack([data, np.ones((len(data), 1))])
                colours = data[np.asarray(original.index)[:, :, offset]].mean(axis=1)
                parts.extend(_split_by_colour(mesh, np.clip(colours, 0.0, 1.0)))
                continue
            effect = getattr(getattr(tris, "material", None), "effect", None)
            parts.append(ColouredMesh(mesh, Appearance(_rgba(getattr(effect, "diffuse", None)))))
    return parts


def read_mesh(path: Path, honour_up_axis: bool = False) -> list[ColouredMesh]:
    """The parts of the mesh file `path`, in metres; raises `UrdfError` if unreadable.

    COLLADA: `<unit meter>` is applied (as rviz does); `<up_axis>` only with
    `honour_up_axis` (rviz ignores it, and files are authored to look right there).
    """
    suffix = path.suffix.lower()
    if suffix == ".stl":
        stl_kind(path)  # a clear error for a truncated file
    try:
        loaded = trimesh.load(str(path), process=False)
        coloured = []
        if suffix == ".dae" and b'semantic="COLOR"' in path.read_bytes():
            coloured = _collada_vertex_coloured(path)
    except Exception as exc:  # trimesh and pycollada raise many types for bad files
        raise UrdfError(f"mesh '{path}' cannot be read: {exc}") from None
    if isinstance(loaded, trimesh.Scene):
        meshes = [g for g in loaded.dump(concatenate=False) if isinstance(g, trimesh.Trimesh)]
    elif isinstance(loaded, trimesh.Trimesh):
        meshes = [loaded]
    else:
        meshes = []
    meshes = [m for m in meshes if len(m.faces)]
    if not meshes and suffix == ".dae":
        fallback = _load_collada_geometry(path)
        meshes = [fallback] if fallback is not None and len(fallback.faces) else []
    if not meshes:
        raise UrdfError(f"mesh '{path}' has no triangles")
    transform = np.eye(4)
    if suffix == ".dae":
        meter, up = collada_frame(path)
        transform = np.diag([meter, meter, meter, 1.0])
        if honour_up_axis:
            transform = _UP_TO_Z.get(up, np.eye(4)) @ transform
    if coloured:
        meshes = []
    parts = []
    for part in coloured:
        part.mesh.apply_transform(transform)
        parts.append(part)
    for mesh in meshes:  # fresh objects from trimesh: transformed in place
        if not np.allclose(transform, np.eye(4)):
            mesh.apply_transform(transform)
        parts.extend(_parts_of(mesh))
    # MuJoCo refuses meshes of fewer than 4 vertices (a stray triangle of one colour)
    solid = [p for p in parts if len(np.unique(p.mesh.faces)) >= 4]
    return solid or parts


def simplify(mesh: trimesh.Trimesh, max_faces: int) -> trimesh.Trimesh:
    """`mesh` with at most `max_faces` faces, by clustering vertices on a grid that is
    coarsened until the face count fits (shape kept to about one grid cell)."""
    if len(mesh.faces) <= max_faces:
        return mesh
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    all_faces = np.asarray(mesh.faces, dtype=np.int64)
    low = vertices.min(axis=0)
    extent = float(np.ptp(vertices, axis=0).max()) or 1.0
    cells = float(np.sqrt(max_faces / 2.0))
    while True:
        n = int(cells) + 1
        keys = np.floor((vertices - low) / (extent / int(cells))).astype(np.int64)
        flat = (keys[:, 0] * n + keys[:, 1]) * n + keys[:, 2]
        _, cluster = np.unique(flat, return_inverse=True)
        faces = cluster.ravel()[all_faces]
        good = (faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2])
        good &= faces[:, 0] != faces[:, 2]
        faces = faces[good]
        ordered = np.sort(faces, axis=1)
        count = int(cluster.max()) + 1
        code = (ordered[:, 0] * count + ordered[:, 1]) * count + ordered[:, 2]
        faces = faces[np.sort(np.unique(code, return_index=True)[1])]
        if len(faces) <= max_faces:
            break
        cells *= 0.95 * float(np.sqrt(max_faces / len(faces)))
    cluster = cluster.ravel()
    centres = np.zeros((count, 3))
    np.add.at(centres, cluster, vertices)
    centres /= np.bincount(cluster, minlength=count)[:, None]
    used, remap = np.unique(faces, return_inverse=True)
    return trimesh.Trimesh(centres[used], remap.reshape(-1, 3), process=False)
