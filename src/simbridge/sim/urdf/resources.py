"""Resolve `package://`, `file://` and relative resource paths the way ROS tools do."""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from urllib.parse import unquote, urlparse

from simbridge.errors import UrdfError

__all__ = ["ResourceResolver"]


@dataclass(frozen=True)
class ResourceResolver:
    """Finds resource files: relative to the URDF's folder, in search paths, in ROS_PACKAGE_PATH.

    A package `pkg` is found as a folder named `pkg` directly inside (or being) a search path
    entry, or up to three levels below it holding a `package.xml` naming it by its folder.
    """

    HOW_TO_ADD = (
        "add the folder that holds it with --search-path DIR, `search_paths: [DIR]` on the "
        "scene's robot, or ROS_PACKAGE_PATH"
    )

    base_dir: Path | None = None
    search_paths: tuple[Path, ...] = ()
    nearby: tuple[Path, ...] = ()
    """Folders checked only for a package folder directly in them or being it (not searched
    below): the URDF's folder and every folder above it."""

    @staticmethod
    def create(
        base_dir: Path | None,
        search_paths: Sequence[str | Path] = (),
        nearby: Sequence[Path] = (),
    ) -> ResourceResolver:
        """A resolver over `search_paths` followed by every ROS_PACKAGE_PATH entry."""
        paths = [Path(p) for p in search_paths]
        env = os.environ.get("ROS_PACKAGE_PATH", "")
        paths.extend(Path(p) for p in env.split(os.pathsep) if p)
        return ResourceResolver(base_dir, tuple(paths), tuple(nearby))

    def package_dir(self, package: str) -> Path | None:
        """The folder of ROS package `package`, or None when no search path holds it."""
        for root in (*self.search_paths, *self.nearby):
            if root.name == package and root.is_dir():
                return root
            direct = root / package
            if direct.is_dir():
                return direct
        for root in self.search_paths:
            if not root.is_dir():
                continue
            for pattern in ("*/package.xml", "*/*/package.xml", "*/*/*/package.xml"):
                for manifest in root.glob(pattern):
                    if manifest.parent.name == package:
                        return manifest.parent
        return None

    def resolve(self, uri: str, element: str) -> Path:
        """The existing file `uri` names; `element` (e.g. "link 'arm' mesh") is used in errors."""
        if uri.startswith("package://"):
            rest = uri[len("package://") :].lstrip("/")  # Talos files say package:///pkg
            package, _, relative = rest.partition("/")
            pkg_dir = self.package_dir(package)
            if pkg_dir is None:
                raise UrdfError(
                    f"{element}: package '{package}' of '{uri}' not found (searched "
                    f"{self.searched()}); {self.HOW_TO_ADD}"
                )
            path = pkg_dir / relative
        elif uri.startswith("file://"):
            path = Path(unquote(urlparse(uri).path))
        else:
            path = Path(uri)
            if not path.is_absolute():
                candidates = [self.base_dir / path] if self.base_dir is not None else []
                candidates.extend(root / path for root in self.search_paths)
                path = next(
                    (c for c in candidates if c.is_file()), candidates[0] if candidates else path
                )
        if not path.is_file():
            raise UrdfError(
                f"{element}: file '{uri}' does not exist (looked at {path}); {self.HOW_TO_ADD}"
            )
        return path.resolve()

    def searched(self) -> str:
        """The folders a package is looked for in, for an error message."""
        folders = [f"{p} (and 3 levels below)" for p in self.search_paths]
        if self.nearby:
            folders.append(f"{self.nearby[0]} and every folder above it")
        return "; ".join(folders) or "no folders"
