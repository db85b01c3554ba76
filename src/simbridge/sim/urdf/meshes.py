"""Mesh files for MuJoCo: what it reads (binary STL and OBJ within its limits) passes
through; everything else (ASCII STL, DAE, PLY, meshes over the limits) is converted once,
into a cache folder, with colours and textures kept for visual geometry."""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import trimesh

from simbridge.sim.urdf.diagnostics import UrdfWarning
from simbridge.sim.urdf.mesh_files import (
    MUJOCO_STL_FACES,
    ColouredMesh,
    read_mesh,
    simplify,
    stl_kind,
)
from simbridge.sim.urdf.transforms import Vec3

__all__ = ["MAX_TEXTURE", "MeshCache", "MeshPart"]

MAX_TEXTURE = 1024
"""Textures are downscaled to at most this many pixels a side."""
_FORMAT = "6"  # bump when conversions change, so stale cache files are not reused
_Rgba = tuple[float, float, float, float]


def _default_cache_dir() -> Path:
    base = os.environ.get("XDG_CACHE_HOME") or str(Path(tempfile.gettempdir()))
    return Path(base) / "simbridge-meshes"


@dataclass(frozen=True)
class MeshPart:
    """One MuJoCo mesh of a visual: its file, own colour and texture (PNG) if the file has them."""

    file: Path
    rgba: _Rgba | None = None
    texture: Path | None = None


def _write_atomic(target: Path, data: bytes) -> None:
    tmp = target.with_suffix(f".{os.getpid()}.tmp")
    tmp.write_bytes(data)
    tmp.replace(target)


def _stl_bytes(mesh: trimesh.Trimesh) -> bytes:
    """Binary STL (what MuJoCo reads fastest); float32 coordinates, as the format has."""
    triangles = np.asarray(mesh.vertices, dtype=np.float64)[np.asarray(mesh.faces)]
    record = np.zeros(len(triangles), dtype=[("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")])
    record["v"] = triangles
    header = b"simbridge".ljust(80, b" ") + np.uint32(len(triangles)).tobytes()
    return header + record.tobytes()


def _obj_bytes(mesh: trimesh.Trimesh) -> bytes:
    """OBJ text with the mesh's UV coordinates (for textured parts)."""
    lines = [f"v {x!r} {y!r} {z!r}" for x, y, z in np.asarray(mesh.vertices, float).tolist()]
    uv = np.asarray(getattr(mesh.visual, "uv", None), dtype=float)
    lines.extend(f"vt {u!r} {v!r}" for u, v in uv[:, :2].tolist())
    faces = (np.asarray(mesh.faces) + 1).tolist()
    lines.extend(f"f {a}/{a} {b}/{b} {c}/{c}" for a, b, c in faces)
    return ("\n".join(lines) + "\n").encode()


@dataclass
class MeshCache:
    """Converts meshes MuJoCo cannot read (or read as meant) into files under `directory`,
    once per content; `honour_up_axis` rotates COLLADA files by their `<up_axis>`."""

    directory: Path = field(default_factory=_default_cache_dir)
    honour_up_axis: bool = False
    _loaded: dict[Path, list[ColouredMesh]] = field(default_factory=dict, repr=False)
    _warned: set[Path] = field(default_factory=set, repr=False)

    def parts(self, path: Path) -> list[ColouredMesh]:
        """The file's parts in metres (read once per cache)."""
        if path not in self._loaded:
            if len(self._loaded) > 256:  # bounded: a scene rarely has this many files
                self._loaded.clear()
            self._loaded[path] = read_mesh(path, self.honour_up_axis)
        return self._loaded[path]

    def load(self, path: Path, scale: Vec3 = (1.0, 1.0, 1.0)) -> trimesh.Trimesh:
        """The mesh in `path` as one triangle mesh in metres, scaled; `UrdfError` if unreadable."""
        pieces = [p.mesh for p in self.parts(path)]
        mesh = trimesh.util.concatenate(pieces) if len(pieces) > 1 else pieces[0].copy()
        assert isinstance(mesh, trimesh.Trimesh)
        mesh.apply_transform(np.diag([*scale, 1.0]))
        return mesh

    def flat_box(
        self, path: Path, scale: Vec3, thickness: float = 0.001
    ) -> tuple[Vec3, Vec3] | None:
        """(centre, size) of a thin box replacing a mesh whose vertices all lie in one plane
        (MuJoCo cannot build the convex hull it collides with); None for solid meshes."""
        mesh = self.load(path, scale)
        spread = mesh.vertices - mesh.vertices.mean(axis=0)
        if np.linalg.matrix_rank(spread, tol=1e-9 * max(1.0, float(np.abs(spread).max()))) == 3:
            return None
        low, high = mesh.bounds
        cx, cy, cz = ((low + high) / 2).tolist()
        sx, sy, sz = np.maximum(high - low, thickness).tolist()
        return (cx, cy, cz), (sx, sy, sz)

    def _digest(self, path: Path) -> str:
        h = hashlib.sha256(path.read_bytes())
        h.update(f"{_FORMAT}:{self.honour_up_axis}".encode())
        return h.hexdigest()[:20]

    def _warn(self, path: Path, element: str, note: Path) -> None:
        """Emit the conversion note of `path` (kept next to the cached file), once per cache."""
        if path not in self._warned and note.is_file():
            self._warned.add(path)
            text = note.read_text()
            warnings.warn(f"{element}: mesh '{path}' {text}", UrdfWarning, stacklevel=4)

    @staticmethod
    def _fit(mesh: trimesh.Trimesh, note: Path) -> trimesh.Trimesh:
        """`mesh`, simplified below MuJoCo's limit if over it (the note says so)."""
        if len(mesh.faces) <= MUJOCO_STL_FACES:
            return mesh
        small = simplify(mesh, MUJOCO_STL_FACES)
        _write_atomic(
            note,
            f"has {len(mesh.faces)} faces, over MuJoCo's limit of {MUJOCO_STL_FACES}; "
            f"simplified to {len(small.faces)} (give a lighter mesh to avoid this)".encode(),
        )
        return small

    def mujoco_file(self, path: Path, element: str = "mesh") -> Path:
        """One file with the whole mesh (in metres) that MuJoCo's loader accepts; for
        collision geometry and objects. `element` names the user in warnings."""
        suffix = path.suffix.lower()
        if suffix == ".stl":
            kind, faces = stl_kind(path)
            if kind == "binary" and faces <= MUJOCO_STL_FACES:
                return path
        elif (
            suffix == ".obj"
            and not self._has_materials(path)
            and len(self.load(path).faces) <= MUJOCO_STL_FACES
        ):
            return path
        target = self.directory / f"{path.stem}-{self._digest(path)}.stl"
        note = target.with_suffix(".note")
        if not target.is_file():
            self.directory.mkdir(parents=True, exist_ok=True)
            mesh = self._fit(self.load(path), note)
            _write_atomic(target, _stl_bytes(mesh))
        self._warn(path, element, note)
        return target

    def _texture_file(self, image: object, stem: str) -> Path:
        """A PNG of `image` for MuJoCo, at most `MAX_TEXTURE` pixels a side (MuJoCo keeps
        textures uncompressed in memory: a 4096^2 texture is 64 MB)."""
        picture = image
        factor = -(-max(picture.size) // MAX_TEXTURE)  # type: ignore[attr-defined]
        if factor > 1:
            picture = picture.reduce(factor)  # type: ignore[attr-defined]
        picture = picture.convert("RGBA")  # type: ignore[attr-defined]
        if picture.getextrema()[3] == (255, 255):
            picture = picture.convert("RGB")
        target = self.directory / f"{stem}.png"
        tmp = target.with_suffix(f".{os.getpid()}.tmp.png")
        picture.save(tmp, compress_level=1)
        tmp.replace(target)
        return target

    @staticmethod
    def _has_materials(path: Path) -> bool:
        with path.open("rb") as f:
            return b"mtllib" in f.read(65536)

    def visual_parts(self, path: Path, element: str = "mesh") -> list[MeshPart]:
        """The files of a visual mesh, one per colour/texture the file carries (a single
        part without colour for files that have none, e.g. STL)."""
        suffix = path.suffix.lower()
        if suffix == ".stl" or (suffix == ".obj" and not self._has_materials(path)):
            return [MeshPart(self.mujoco_file(path, element))]
        digest = self._digest(path)
        manifest = self.directory / f"{path.stem}-{digest}.json"
        note = manifest.with_suffix(".note")
        if not manifest.is_file():
            self.directory.mkdir(parents=True, exist_ok=True)
            entries = []
            for i, part in enumerate(self.parts(path)):
                mesh = self._fit(part.mesh, note)
                textured = part.look.texture is not None and mesh is part.mesh
                file = self.directory / f"{path.stem}-{digest}-{i}.{'obj' if textured else 'stl'}"
                _write_atomic(file, _obj_bytes(mesh) if textured else _stl_bytes(mesh))
                texture = None
                if textured:
                    texture = self._texture_file(part.look.texture, f"{path.stem}-{digest}-{i}")
                entries.append(
                    {"file": file.name, "rgba": part.look.rgba, "texture": texture and texture.name}
                )
            _write_atomic(manifest, json.dumps(entries).encode())
        self._warn(path, element, note)
        entries = json.loads(manifest.read_text())
        return [
            MeshPart(
                self.directory / e["file"],
                tuple(e["rgba"]) if e["rgba"] else None,  # type: ignore[arg-type]
                self.directory / e["texture"] if e["texture"] else None,
            )
            for e in entries
        ]
