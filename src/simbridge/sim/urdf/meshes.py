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
