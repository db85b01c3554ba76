"""Load URDF or xacro files into a `Robot`, resolving packages and mesh files."""

from __future__ import annotations

import threading
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path

import xacro
from xacro import substitution_args

from simbridge.errors import UrdfError
from simbridge.sim.urdf.parser import parse_urdf
from simbridge.sim.urdf.resources import ResourceResolver
from simbridge.sim.urdf.robot import Robot

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
            searched = ", ".join(str(p) for p in resolver.search_paths) or "none"
            raise UrdfError(
                f"$(find {package}): package '{package}' not found (search paths: {searched}; "
                "add one with --search-path/search_paths or set ROS_PACKAGE_PATH)"
            )
        return str(found)

    original = substitution_args._eval_find
    substitution_args._eval_find = find
    try:
        yield
    finally:
        substitution_args._eval_find = original


class _ArgTable(dict[str, str]):
    """xacro's `$(arg)` table; remembers every name a document declares or reads, so args
    given on the command line that the document never mentions can be reported."""

    def __init__(self, given: Mapping[str, str]) -> None:
        super().__init__(given)
        self.mentioned: set[str] = set()

    def __contains__(self, key: object) -> bool:  # `<xacro:arg name=...>` asks this
        self.mentioned.add(str(key))
        return super().__contains__(key)

    def __getitem__(self, key: str) -> str:  # `$(arg name)` reads this
        self.mentioned.add(key)
        return super().__getitem__(key)


def _xacro_error(path: Path, exc: Exception) -> UrdfError:
    """One plain message for what went wrong inside xacro: the innermost cause, once."""
    inner: BaseException = exc
    while isinstance(getattr(inner, "exc", None), BaseException):
        inner = inner.exc  # type: ignore[attr-defined]
    if isinstance(inner, UrdfError) or inner is exc:
        text = str(inner)
    else:  # xacro wraps causes as "<class 'X'>: text" + the cause again
        head = str(exc.args[0]) if exc.args and exc.args[0] else ""
        text = str(inner) if not head or head.startswith(str(type(inner))) else f"{head} {inner}"
    stack = [str(f) for f in getattr(xacro, "filestack", None) or [] if f]
    return UrdfError(f"{stack[-1] if stack else path}: xacro: {text}")


def expand_xacro(
    path: Path, mappings: Mapping[str, str] | None = None, resolver: ResourceResolver | None = None
) -> str:
    """The URDF text xacro produces from `path` with `mappings` as its `$(arg ...)` values.

    An arg in `mappings` that the document neither declares nor reads is an error (a typo
    would otherwise be ignored silently).
    """
    resolver = resolver or ResourceResolver.create(path.parent)
    table = _ArgTable(mappings or {})
    with _XACRO_LOCK, _find_through(resolver):
        try:
            doc = xacro.process_file(str(path), mappings=table)
        except Exception as exc:  # xacro raises XacroException, ExpatError, NameError...
            raise _xacro_error(path, exc) from None
    unknown = sorted(set(mappings or {}) - table.mentioned)
    if unknown:
        declared = sorted(table.mentioned)
        raise UrdfError(
            f"{path}: unknown xacro arg(s) {', '.join(unknown)} "
            f"(the file declares: {', '.join(declared) or 'none'})"
        )
    return str(doc.toprettyxml(indent="  "))


def load_urdf(
    path: str | Path,
    *,
    search_paths: Sequence[str | Path] = (),
    xacro_args: Mapping[str, str] | None = None,
    strict: bool = False,
) -> Robot:
    """Parse a .urdf or .xacro file; meshes resolve via the file's folder, `search_paths`
    and ROS_PACKAGE_PATH (the file's own folder and every one above count as package roots).
    `strict` turns tolerated defects (duplicate definitions...) into errors."""
    file = Path(path)
    if not file.is_file():
        raise UrdfError(f"URDF file '{file}' does not exist")
    here = file.resolve()
    # Packages next to the file or above it are found without flags (example-robot-data's
    # robots name package://example-robot-data/robots/..., four folders up).
    resolver = ResourceResolver.create(here.parent, search_paths, tuple(here.parents))
    text = file.read_text()
    expanded = is_xacro(file, text)
    if expanded:
        text = expand_xacro(file, xacro_args, resolver)
    elif xacro_args:
        raise UrdfError(
            f"{file}: xacro args {', '.join(sorted(xacro_args))} given, but the file is not "
            "xacro (no .xacro suffix, no xmlns:xacro)"
        )
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
