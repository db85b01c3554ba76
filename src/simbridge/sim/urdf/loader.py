"""Load URDF or xacro files into a `Robot`, resolving packages and mesh files."""

from __future__ import annotations

import threading
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path

import xacro
from xacro import substitution_args

from simbridge.errors import UrdfError
from simbridge.sim.urdf.model import Robot
from simbridge.sim.urdf.parser import parse_urdf
from simbridge.sim.urdf.resources import ResourceResolver

__all__ = ["expand_xacro", "is_xacro", "load_urdf", "load_urdf_string"]

_XACRO_LOCK = threading.Lock()  # xacro keeps its state in module globals


def is_xacro(path: Path, text: str) -> bool:
    """Whether `path` needs xacro: a .xacro suffix or a xacro namespace in the text."""
    return path.suffix == ".xacro" or "xmlns:xacro" in text


@contextmanager
def _find_through(resolver: ResourceResolver) -> Iterator[None]:
    """Make xacro's `$(find pkg)` use our resolver instead of a ROS installation."""

    def find(package: str) -> str:
        found = resolver.package_dir(package)
        if found is None:
            raise UrdfError(f"xacro $(find {package}): package not found in search paths")
        return str(found)

    original = substitution_args._eval_find
    substitution_args._eval_find = find
    try:
        yield
    finally:
        substitution_args._eval_find = original


def expand_xacro(
    path: Path, mappings: Mapping[str, str] | None = None, resolver: ResourceResolver | None = None
) -> str:
    """The URDF text xacro produces from `path` with `mappings` as its `$(arg ...)` values."""
    resolver = resolver or ResourceResolver.create(path.parent)
    with _XACRO_LOCK, _find_through(resolver):
        try:
            doc = xacro.process_file(str(path), mappings=dict(mappings or {}))
        except UrdfError:
            raise
        except Exception as exc:  # xacro raises XacroException, ExpatError, NameError...
            raise UrdfError(f"xacro failed on {path}: {exc}") from None
    return str(doc.toprettyxml(indent="  "))


def load_urdf(
    path: str | Path,
    *,
    search_paths: Sequence[str | Path] = (),
    xacro_args: Mapping[str, str] | None = None,
    strict: bool = False,
) -> Robot:
    """Parse a .urdf or .xacro file; meshes resolve via the file's folder, `search_paths`
    and ROS_PACKAGE_PATH (the file's own folder and its parents count as package roots).
    `strict` turns tolerated defects (duplicate definitions...) into errors."""
    file = Path(path)
    if not file.is_file():
        raise UrdfError(f"URDF file '{file}' does not exist")
    here = file.resolve()
    resolver = ResourceResolver.create(here.parent, search_paths, here.parents[:3])
    text = file.read_text()
    expanded = is_xacro(file, text)
    if expanded:
        text = expand_xacro(file, xacro_args, resolver)
    return parse_urdf(text, source=file, resolver=resolver, strict=strict, lines_valid=not expanded)


def load_urdf_string(
    text: str,
    *,
    base_dir: str | Path | None = None,
    search_paths: Sequence[str | Path] = (),
    strict: bool = False,
) -> Robot:
    """Parse URDF text (e.g. a `robot_description` parameter); relative meshes use `base_dir`."""
    resolver = ResourceResolver.create(Path(base_dir) if base_dir else None, search_paths)
    return parse_urdf(text, resolver=resolver, strict=strict)
