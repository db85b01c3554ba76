"""ROS 2 interface classes for the TCP side's type names.

Clients name types as in ROS 1 (`geometry_msgs/Twist`, `std_srvs/Trigger`); ROS 2
wants `geometry_msgs/msg/Twist` and imports the class from the package's Python
module. Packages without a wheel are built into the ROS 2 venv with
`simbridge msg build`; a missing one gets an error that says so.
"""

from __future__ import annotations

import importlib
from typing import Any

from simbridge.errors import EndpointError

__all__ = ["Ros2Types", "ros2_type_name", "tcp_type_name"]


def _split(name: str, kind: str) -> tuple[str, str]:
    parts = [p for p in name.strip().strip("\0").split("/") if p]
    if len(parts) == 3 and parts[1] == kind:
        parts = [parts[0], parts[2]]
    if len(parts) != 2:
        raise EndpointError(f"type name {name!r} is not of the form package/Type")
    return parts[0], parts[1]


def ros2_type_name(name: str, kind: str = "msg") -> str:
    """`pkg/Type` (or `pkg/msg/Type`) -> `pkg/msg/Type`."""
    package, base = _split(name, kind)
    return f"{package}/{kind}/{base}"


def tcp_type_name(name: str) -> str:
    """`pkg/msg/Type` -> `pkg/Type`, the form Unity's topic list expects."""
    parts = name.split("/")
    if len(parts) == 3:
        return f"{parts[0]}/{parts[2]}"
    return name


class Ros2Types:
    """Imports (and caches) rclpy message and service classes by name."""

    def __init__(self) -> None:
        self._cache: dict[tuple[str, str], Any] = {}

    def message(self, name: str) -> Any:
        """The message class for `pkg/Type`."""
        return self._load(name, "msg")

    def service(self, name: str) -> Any:
        """The service class for `pkg/Service` (with .Request and .Response)."""
        return self._load(name, "srv")

    def action(self, name: str) -> Any:
        """The action class for `pkg/Action` (with .Goal, .Result, .Feedback)."""
        return self._load(name, "action")

    def _load(self, name: str, kind: str) -> Any:
        package, base = _split(name, kind)
        key = (package, f"{kind}/{base}")
        cls = self._cache.get(key)
        if cls is not None:
            return cls
        try:
            module = importlib.import_module(f"{package}.{kind}")
            cls = getattr(module, base)
        except (ImportError, AttributeError) as exc:
            raise EndpointError(
                f"no ROS 2 interface {package}/{kind}/{base} is installed ({exc}); build its "
                f"package into the ROS 2 venv with `simbridge msg build PKG_DIR`"
            ) from exc
        self._cache[key] = cls
        return cls
