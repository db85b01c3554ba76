"""Package faces loaded on first use (PEP 562): `from pkg import Name` imports Name's module
then, so importing one module of a package does not load its siblings (nor rospy, rclpy,
MuJoCo or Gymnasium). Every layer's faces use it."""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable, Mapping

__all__ = ["lazy_face"]


def lazy_face(
    package: str, exports: Mapping[str, str]
) -> tuple[Callable[[str], object], Callable[[], list[str]]]:
    """`__getattr__` and `__dir__` for `package`, whose public `exports` map each name to the
    module (relative to `package`) that defines it, or to `module:attribute` where the
    module calls it otherwise. A name is imported at its first use and kept in the
    package's namespace, so later uses are plain attribute reads."""

    def __getattr__(name: str) -> object:  # noqa: N807 - the module hook's own name
        where = exports.get(name)
        if where is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        module, _, attribute = where.partition(":")
        value = getattr(importlib.import_module(f"{package}.{module}"), attribute or name)
        setattr(sys.modules[package], name, value)
        return value

    def __dir__() -> list[str]:  # noqa: N807 - the module hook's own name
        return sorted({*exports, *vars(sys.modules[package])})

    return __getattr__, __dir__
