"""Type-name spelling: ROS 1 `pkg/Type` is canonical; `pkg/msg/Type` and friends are accepted."""

from __future__ import annotations

import re
from dataclasses import dataclass

__all__ = ["TypeName", "parse_type_name", "store_name"]

_PART = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")
_SERVICE_PART = re.compile(r"^(?P<base>.+?)_?(?P<part>Request|Response)$")
_ACTION_PART = re.compile(
    r"^(?P<base>.+?)_(?P<part>Goal|Result|FeedbackMessage|Feedback|"
    r"SendGoal(?:_Request|_Response)?|GetResult(?:_Request|_Response)?)$"
)


@dataclass(frozen=True, slots=True)
class TypeName:
    """A parsed type name: package, type, and the interface kind it was spelled with."""

    package: str
    name: str
    kind: str
    """"msg", "srv" or "action" as written ("msg" when the name had no middle part)."""

    @property
    def canonical(self) -> str:
        """The ROS 1 spelling, `pkg/Type`."""
        return f"{self.package}/{self.name}"


def parse_type_name(text: str) -> TypeName | None:
    """Parse `pkg/Type`, `pkg/msg/Type`, `pkg/srv/Type[_]Request` or `pkg/action/Type...`.

    Service parts written ROS 2 style (`Foo_Request`) map to the ROS 1 type
    `FooRequest`, action parts (`Fib_Goal`, `Fib_SendGoal_Request`) to `FibGoal`,
    `FibSendGoalRequest`. Returns None when the text is not a well-formed name.
    """
    parts = text.strip().split("/")
    if len(parts) == 2:
        package, kind, name = parts[0], "msg", parts[1]
    elif len(parts) == 3 and parts[1] in ("msg", "srv", "action"):
        package, kind, name = parts
    else:
        return None
    if not (_PART.match(package) and _PART.match(name)):
        return None
    if kind == "srv" and (match := _SERVICE_PART.match(name)):
        name = match["base"] + match["part"]
    elif kind == "action" and (match := _ACTION_PART.match(name)):
        name = match["base"] + match["part"].replace("_", "")
    return TypeName(package, name, kind)


def store_name(canonical: str) -> str:
    """The rosbags typestore key of a canonical message name: `pkg/msg/Type`, which is
    also the ROS 2 (rosidl) name of a plain message."""
    package, _, name = canonical.partition("/")
    return f"{package}/msg/{name}"
