"""Mesh files for MuJoCo: STL and OBJ pass through, other formats (DAE, PLY, ...) are converted."""

from __future__ import annotations

import hashlib
import os
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import trimesh

from simbridge.errors import UrdfError
from simbridge.sim.urdf.transforms import Vec3

__all__ = ["MeshCache"]

_NATIVE = {".stl", ".obj"}


def _default_cache_dir() -> Path:
    base = os.environ.get("XDG_CACHE_HOME") or str(Path(tempfile.gettempdir()))
    return Path(base) / "simbridge-meshes"


@dataclass
class MeshCache:
    """Converts meshes MuJoCo cannot read into OBJ files under `directory`, once per content."""

    directory: Path = field(default_factory=_default_cache_dir)

    def load(self, path: Path, scale: Vec3 = (1.0, 1.0, 1.0)) -> trimesh.Trimesh:
        """The mesh in `path` as one triangle mesh, scaled; raises `UrdfError` if unreadable."""
        try:
            loaded = trimesh.load(str(path), force="mesh")
        except Exception as exc:  # trimesh raises many types for bad files
            raise UrdfError(f"mesh '{path}' cannot be read: {exc}") from None
        if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0:
            raise UrdfError(f"mesh '{path}' has no triangles")
        mesh = loaded.copy()
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

    def mujoco_file(self, path: Path) -> Path:
        """A file with the same geometry that MuJoCo's mesh loader accepts."""
        if path.suffix.lower() in _NATIVE:
            return path
        digest = hashlib.sha256(path.read_bytes()).hexdigest()[:20]
        target = self.directory / f"{path.stem}-{digest}.obj"
        if not target.is_file():
            mesh = self.load(path)
            self.directory.mkdir(parents=True, exist_ok=True)
            tmp = target.with_suffix(f".{os.getpid()}.tmp")
            tmp.write_text(str(trimesh.exchange.obj.export_obj(mesh, include_texture=False)))  # type: ignore[no-untyped-call]
            tmp.replace(target)
        return target
