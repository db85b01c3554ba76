"""System commands (`__name` + JSON payload) of ROS-TCP v0.7.0, as typed values.

Each command is a frozen dataclass with `encode()` giving its frame. `decode_command`
turns a received frame into one, checking every field and naming the bad value.
"""

from __future__ import annotations

import json
import re
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, ClassVar, Literal, TypeVar, get_args

from simbridge.errors import ProtocolError
from simbridge.protocol.framing import encode_frame

__all__ = [
    "EXTENSIONS",
    "MAX_COMMAND_SIZE",
    "MAX_NAME_LENGTH",
    "MAX_QUEUE_SIZE",
    "PROTOCOL_VERSION",
    "ClientCommand",
    "Command",
    "EndpointCommand",
    "ErrorMessage",
    "Handshake",
    "LogMessage",
    "Publish",
    "RemovePublisher",
    "RemoveRosService",
    "RemoveSubscriber",
    "RemoveUnityService",
    "RosService",
    "ServiceFailure",
    "ServiceHeader",
    "ServiceRequestHeader",
    "ServiceResponseHeader",
    "SetParam",
    "StatsReply",
    "StatsRequest",
    "Subscribe",
    "SubscriberCount",
    "TopicListReply",
    "TopicListRequest",
    "UnityService",
    "WarnMessage",
    "decode_command",
    "register_command",
    "shorten",
]

PROTOCOL_VERSION = "v0.7.0"
EXTENSIONS = (
    "keepalive",
    "error_srv_id",
    "stats",
    "subscribers",
    "service_error",
    "set_param",
    "subscribe_queue",
)
"""simbridge additions an endpoint announces in its handshake metadata (`extensions`)."""
DEFAULT_SUBSCRIBE_QUEUE = 100
"""Per-client send queue bound for a subscription that names none (simbridge extension)."""

MAX_NAME_LENGTH = 256
"""Longest topic, service or type name accepted (characters); longer ones are refused
before any work (close-match suggestions, registration) is spent on them."""
MAX_QUEUE_SIZE = 1_000_000
"""Largest `queue_size` the endpoint honours; larger requests are capped to it (a
negative one is an error), so a client cannot make one queue unbounded."""
MAX_COMMAND_SIZE = 1024 * 1024
"""Largest system-command payload (JSON) accepted, in bytes."""
_MAX_DIGITS = 20
"""Longest integer literal parsed from a command (int64 needs 19 digits and a sign)."""
_MAX_INT = 2**63 - 1
_NAME = re.compile(r"[~/A-Za-z_][A-Za-z0-9_/]*\Z", re.ASCII)
_TYPE = re.compile(r"[A-Za-z][A-Za-z0-9_]*(?:/[A-Za-z][A-Za-z0-9_]*){0,2}\Z", re.ASCII)

Sender = Literal["client", "endpoint"]


def shorten(value: object, limit: int = 80) -> str:
    """`repr(value)` cut to about `limit` characters, for echoing untrusted text safely.

    Errors and logs quote names a client sent; a megabyte name must not become a
    megabyte log line, and lone surrogates come out escaped.
    """
    if isinstance(value, str | bytes) and len(value) > limit:
        return f"{value[:limit]!r}... ({len(value):,} characters)"
    text = repr(value)
    return text if len(text) <= limit + 20 else f"{text[:limit]}... ({len(text):,} characters)"


def _parse_int(text: str) -> int:
    if len(text) > _MAX_DIGITS:
        raise ProtocolError(f"integer literal of {len(text):,} digits; at most {_MAX_DIGITS}")
    return int(text)


def _json_payload(name: str, payload: bytes) -> dict[str, Any]:
    if len(payload) > MAX_COMMAND_SIZE:
        raise ProtocolError(
            f"{name}: payload of {len(payload):,} bytes exceeds {MAX_COMMAND_SIZE:,} bytes"
        )
    text_bytes = payload.rstrip(b"\x00")
    if not text_bytes.strip():
        return {}
    try:
        obj = json.loads(text_bytes, parse_int=_parse_int)
    except ProtocolError as exc:
        raise ProtocolError(f"{name}: {exc}") from None
    except RecursionError:
        raise ProtocolError(f"{name}: payload JSON is nested too deeply") from None
    except (UnicodeDecodeError, ValueError) as exc:
        preview = text_bytes[:80].decode("utf-8", "replace")
        reason = shorten(str(exc), 120)
        raise ProtocolError(f"{name}: payload is not valid JSON ({reason}): {preview!r}") from None
    if not isinstance(obj, dict):
        raise ProtocolError(f"{name}: payload must be a JSON object, got {type(obj).__name__}")
    return obj


def _get_str(name: str, obj: dict[str, Any], key: str) -> str:
    value = obj.get(key)
    if not isinstance(value, str):
        raise ProtocolError(f"{name}: field {key!r} must be a string, got {shorten(value)}")
    try:
        value.encode()
    except UnicodeEncodeError:
        raise ProtocolError(
            f"{name}: field {key!r} {shorten(value)} holds a lone surrogate; not valid Unicode"
        ) from None
    return value.rstrip("\x00")


def _get_name(name: str, obj: dict[str, Any], key: str, *, kind: str = "ros") -> str:
    """A topic/service name (`kind` "ros") or a type name (`kind` "type"), validated."""
    value = _get_str(name, obj, key)
    if not value.strip():
        example = "'/cmd_vel'" if kind == "ros" else "'std_msgs/String'"
        raise ProtocolError(f"{name}: {key!r} is blank; expected a name such as {example}")
    if len(value) > MAX_NAME_LENGTH:
        raise ProtocolError(
            f"{name}: {key!r} {shorten(value)} is longer than {MAX_NAME_LENGTH} characters"
        )
    if any(c.isspace() for c in value):
        raise ProtocolError(f"{name}: {key!r} {shorten(value)} contains whitespace")
    if kind == "ros":
        if not _NAME.match(value) or "//" in value or value in ("/", "~"):
            raise ProtocolError(
                f"{name}: {key!r} {shorten(value)} is not a valid ROS name; expected ASCII "
                "letters, digits, '_' and '/' (no '//'), starting with a letter, '_', '/' or '~'"
            )
    elif not _TYPE.match(value):
        raise ProtocolError(
            f"{name}: {key!r} {shorten(value)} is not a valid type name; expected "
            "pkg/Type or pkg/msg/Type (ASCII letters, digits and '_')"
        )
    return value


def _get_int(
    name: str,
    obj: dict[str, Any],
    key: str,
    default: int | None = None,
    *,
    low: int = -_MAX_INT - 1,
    high: int = _MAX_INT,
) -> int:
    value = obj.get(key, default)
    if isinstance(value, bool) or not isinstance(value, int):
        raise ProtocolError(f"{name}: field {key!r} must be an integer, got {shorten(value)}")
    if not low <= value <= high:
        raise ProtocolError(f"{name}: field {key!r} must be in {low}..{high}, got {value}")
    return value


def _queue_size(name: str, obj: dict[str, Any], default: int) -> int:
    """`queue_size`: >= 0, capped at MAX_QUEUE_SIZE."""
    return min(_get_int(name, obj, "queue_size", default, low=0), MAX_QUEUE_SIZE)


def _get_bool(name: str, obj: dict[str, Any], key: str, default: bool) -> bool:
    value = obj.get(key, default)
    if not isinstance(value, bool):
        raise ProtocolError(f"{name}: field {key!r} must be true or false, got {shorten(value)}")
    return value


class Command:
    """Base of every system command."""

    NAME: ClassVar[str] = ""

    def to_json(self) -> dict[str, Any]:
        """The JSON object sent as payload."""
        raise NotImplementedError

    def encode(self) -> bytes:
        """The complete frame."""
        return encode_frame(self.NAME, json.dumps(self.to_json()).encode())

    @classmethod
    def from_json(cls, obj: dict[str, Any]) -> Command:
        """Build from a decoded payload; raises ProtocolError naming the bad field."""
        raise NotImplementedError


@dataclass(frozen=True, slots=True)
class _TopicTyped(Command):
    """A command naming a topic and its type. Subclasses extend `to_json` through
    `_TopicTyped.to_json(self)`: zero-argument super() fails in a slots dataclass."""

    topic: str
    message_name: str

    def to_json(self) -> dict[str, Any]:
        return {"topic": self.topic, "message_name": self.message_name}

    @classmethod
    def from_json(cls, obj: dict[str, Any]) -> Command:
        return cls(*cls._topic_and_type(obj))

    @classmethod
    def _topic_and_type(cls, obj: dict[str, Any]) -> tuple[str, str]:
        """The payload's `topic` and `message_name`, validated."""
        topic = _get_name(cls.NAME, obj, "topic")
        return topic, _get_name(cls.NAME, obj, "message_name", kind="type")


@dataclass(frozen=True, slots=True)
class Subscribe(_TopicTyped):
    """Client wants every message on `topic`; `queue_size` bounds its send queue."""

    NAME: ClassVar[str] = "__subscribe"
    queue_size: int = DEFAULT_SUBSCRIBE_QUEUE

    def to_json(self) -> dict[str, Any]:
        obj = _TopicTyped.to_json(self)
        if self.queue_size != DEFAULT_SUBSCRIBE_QUEUE:  # the default: Unity's exact bytes
            obj["queue_size"] = self.queue_size
        return obj

    @classmethod
    def from_json(cls, obj: dict[str, Any]) -> Command:
        queue = _queue_size(cls.NAME, obj, DEFAULT_SUBSCRIBE_QUEUE)
        return cls(*cls._topic_and_type(obj), queue if queue > 0 else DEFAULT_SUBSCRIBE_QUEUE)


@dataclass(frozen=True, slots=True)
class Publish(_TopicTyped):
    """Client will publish on `topic`."""

    NAME: ClassVar[str] = "__publish"
    queue_size: int = 10
    latch: bool = False
    report_subscribers: bool = False
    """simbridge extension: ask for `__subscribers` counts (only sent when true)."""

    def to_json(self) -> dict[str, Any]:
        obj = _TopicTyped.to_json(self)
        obj.update(queue_size=self.queue_size, latch=self.latch)
        if self.report_subscribers:
            obj["report_subscribers"] = True
        return obj

    @classmethod
    def from_json(cls, obj: dict[str, Any]) -> Command:
        queue = _queue_size(cls.NAME, obj, 10)
        return cls(
            *cls._topic_and_type(obj),
            queue,
            _get_bool(cls.NAME, obj, "latch", False),
            _get_bool(cls.NAME, obj, "report_subscribers", False),
        )


@dataclass(frozen=True, slots=True)
class RosService(_TopicTyped):
    """Client will call the ROS service `topic`."""

    NAME: ClassVar[str] = "__ros_service"


@dataclass(frozen=True, slots=True)
class UnityService(_TopicTyped):
    """Client implements the service `topic`; the endpoint advertises it."""

    NAME: ClassVar[str] = "__unity_service"


@dataclass(frozen=True, slots=True)
class _TopicOnly(Command):
    topic: str

    def to_json(self) -> dict[str, Any]:
        return {"topic": self.topic}

    @classmethod
    def from_json(cls, obj: dict[str, Any]) -> Command:
        return cls(_get_name(cls.NAME, obj, "topic"))


@dataclass(frozen=True, slots=True)
class RemoveSubscriber(_TopicOnly):
    """Undo `__subscribe`."""

    NAME: ClassVar[str] = "__remove_subscriber"


@dataclass(frozen=True, slots=True)
class RemovePublisher(_TopicOnly):
    """Undo `__publish`."""

    NAME: ClassVar[str] = "__remove_publisher"


@dataclass(frozen=True, slots=True)
class RemoveRosService(_TopicOnly):
    """Undo `__ros_service`."""

    NAME: ClassVar[str] = "__remove_ros_service"


@dataclass(frozen=True, slots=True)
class RemoveUnityService(_TopicOnly):
    """Undo `__unity_service`."""

    NAME: ClassVar[str] = "__remove_unity_service"


@dataclass(frozen=True, slots=True)
class ServiceHeader(Command):
    """`__request`/`__response`: the next frame on the connection is a service frame."""

    srv_id: int

    def to_json(self) -> dict[str, Any]:
        return {"srv_id": self.srv_id}

    @classmethod
    def from_json(cls, obj: dict[str, Any]) -> Command:
        return cls(_get_int(cls.NAME, obj, "srv_id", low=-(2**31), high=2**32 - 1))


@dataclass(frozen=True, slots=True)
class ServiceRequestHeader(ServiceHeader):
    """The next frame is a service request with this id."""

    NAME: ClassVar[str] = "__request"


@dataclass(frozen=True, slots=True)
class ServiceResponseHeader(ServiceHeader):
    """The next frame is the response to the request with this id."""

    NAME: ClassVar[str] = "__response"


@dataclass(frozen=True, slots=True)
class _NoFields(Command):
    def to_json(self) -> dict[str, Any]:
        return {}

    @classmethod
    def from_json(cls, obj: dict[str, Any]) -> Command:
        return cls()


@dataclass(frozen=True, slots=True)
class TopicListRequest(_NoFields):
    """Client asks for the graph's topics."""

    NAME: ClassVar[str] = "__topic_list"


@dataclass(frozen=True, slots=True)
class TopicListReply(Command):
    """Endpoint's answer: parallel lists of topic names and types."""

    NAME: ClassVar[str] = "__topic_list"
    topics: tuple[str, ...]
    types: tuple[str, ...]

    def to_json(self) -> dict[str, Any]:
        return {"topics": list(self.topics), "types": list(self.types)}

    @classmethod
    def from_json(cls, obj: dict[str, Any]) -> Command:
        topics, types = obj.get("topics", []), obj.get("types", [])
        if not isinstance(topics, list) or not all(isinstance(t, str) for t in topics):
            raise ProtocolError(
                f"{cls.NAME}: 'topics' must be a list of strings, got {shorten(topics)}"
            )
        if not isinstance(types, list) or not all(isinstance(t, str) for t in types):
            raise ProtocolError(
                f"{cls.NAME}: 'types' must be a list of strings, got {shorten(types)}"
            )
        if len(topics) != len(types):
            raise ProtocolError(
                f"{cls.NAME}: {len(topics)} topics but {len(types)} types; they must pair up"
            )
        return cls(tuple(topics), tuple(types))


@dataclass(frozen=True, slots=True)
class Handshake(Command):
    """First frame from the endpoint: protocol version and metadata (a JSON string)."""

    NAME: ClassVar[str] = "__handshake"
    version: str = PROTOCOL_VERSION
    metadata: dict[str, Any] = field(default_factory=lambda: {"protocol": "ROS1"})

    def to_json(self) -> dict[str, Any]:
        return {"version": self.version, "metadata": json.dumps(self.metadata)}

    @classmethod
    def from_json(cls, obj: dict[str, Any]) -> Command:
        version = _get_str(cls.NAME, obj, "version")
        raw = obj.get("metadata", "{}")
        meta: Any = raw
        if isinstance(raw, str):
            try:
                meta = json.loads(raw, parse_int=_parse_int) if raw.strip() else {}
            except (ProtocolError, RecursionError, ValueError):
                raise ProtocolError(
                    f"{cls.NAME}: metadata {shorten(raw)} is not a JSON string"
                ) from None
        if not isinstance(meta, dict):
            raise ProtocolError(f"{cls.NAME}: metadata must be a JSON object, got {shorten(raw)}")
        return cls(version, meta)

    @property
    def protocol(self) -> str:
        """ "ROS1" or "ROS2"."""
        return str(self.metadata.get("protocol", "ROS1"))


@dataclass(frozen=True, slots=True)
class _Text(Command):
    text: str
    srv_id: int | None = None
    """simbridge extension on `__error`: the failed service call it answers."""
    goal_id: int | None = None
    """simbridge extension `actions` on `__error`: the client's action goal that failed."""

    def to_json(self) -> dict[str, Any]:
        obj: dict[str, Any] = {"text": self.text}
        if self.srv_id is not None:
            obj["srv_id"] = self.srv_id
        if self.goal_id is not None:
            obj["goal_id"] = self.goal_id
        return obj

    @classmethod
    def from_json(cls, obj: dict[str, Any]) -> Command:
        srv_id = obj.get("srv_id")
        if srv_id is not None:
            srv_id = _get_int(cls.NAME, obj, "srv_id", low=-(2**31), high=2**32 - 1)
        goal_id = obj.get("goal_id")
        if goal_id is not None:
            goal_id = _get_int(cls.NAME, obj, "goal_id", low=0)
        return cls(_get_str(cls.NAME, obj, "text"), srv_id, goal_id)


@dataclass(frozen=True, slots=True)
class LogMessage(_Text):
    """Information for the client's console."""

    NAME: ClassVar[str] = "__log"


@dataclass(frozen=True, slots=True)
class WarnMessage(_Text):
    """A warning for the client's console (e.g. dropped messages)."""

    NAME: ClassVar[str] = "__warn"


@dataclass(frozen=True, slots=True)
class ErrorMessage(_Text):
    """A bad request; with `srv_id` it fails that service call (simbridge extension)."""

    NAME: ClassVar[str] = "__error"


@dataclass(frozen=True, slots=True)
class SubscriberCount(Command):
    """simbridge extension: how many subscribers a topic the client publishes has now."""

    NAME: ClassVar[str] = "__subscribers"
    topic: str
    count: int

    def to_json(self) -> dict[str, Any]:
        return {"topic": self.topic, "count": self.count}

    @classmethod
    def from_json(cls, obj: dict[str, Any]) -> Command:
        return cls(_get_name(cls.NAME, obj, "topic"), _get_int(cls.NAME, obj, "count", low=-1))


@dataclass(frozen=True, slots=True)
class ServiceFailure(Command):
    """simbridge extension: the client's handler for request `srv_id` failed (instead of
    a `__response`), so the ROS caller gets the error at once rather than a timeout."""

    NAME: ClassVar[str] = "__service_error"
    srv_id: int
    text: str

    def to_json(self) -> dict[str, Any]:
        return {"srv_id": self.srv_id, "text": self.text}

    @classmethod
    def from_json(cls, obj: dict[str, Any]) -> Command:
        return cls(
            _get_int(cls.NAME, obj, "srv_id", low=-(2**31), high=2**32 - 1),
            _get_str(cls.NAME, obj, "text"),
        )


@dataclass(frozen=True, slots=True)
class SetParam(Command):
    """simbridge extension: set the ROS parameter `name` to `value` (any JSON value but
    null), e.g. the sim's `/robot_description`. Failures come back as an `__error`."""

    NAME: ClassVar[str] = "__set_param"
    name: str
    value: Any

    def to_json(self) -> dict[str, Any]:
        return {"name": self.name, "value": self.value}

    @classmethod
    def from_json(cls, obj: dict[str, Any]) -> Command:
        name = _get_name(cls.NAME, obj, "name")
        if "value" not in obj or obj["value"] is None:
            raise ProtocolError(
                f"{cls.NAME}: parameter {shorten(name)} has no 'value'; expected a string, "
                "number, boolean, list or object (ROS parameters cannot be null)"
            )
        return cls(name, obj["value"])


@dataclass(frozen=True, slots=True)
class StatsRequest(_NoFields):
    """simbridge extension: ask the endpoint for this connection's counters."""

    NAME: ClassVar[str] = "__stats"


@dataclass(frozen=True, slots=True)
class StatsReply(Command):
    """simbridge extension: counters (frames, bytes, drops per topic)."""

    NAME: ClassVar[str] = "__stats"
    stats: dict[str, Any]

    def to_json(self) -> dict[str, Any]:
        return self.stats

    @classmethod
    def from_json(cls, obj: dict[str, Any]) -> Command:
        return cls(obj)


ClientCommand = (
    Subscribe
    | Publish
    | RosService
    | UnityService
    | RemoveSubscriber
    | RemovePublisher
    | RemoveRosService
    | RemoveUnityService
    | ServiceRequestHeader
    | ServiceResponseHeader
    | TopicListRequest
    | StatsRequest
    | ServiceFailure
    | SetParam
)
EndpointCommand = (
    Handshake
    | LogMessage
    | WarnMessage
    | ErrorMessage
    | ServiceRequestHeader
    | ServiceResponseHeader
    | TopicListReply
    | StatsReply
    | SubscriberCount
)

_FROM_CLIENT: dict[str, type[Command]] = {c.NAME: c for c in get_args(ClientCommand)}
_FROM_ENDPOINT: dict[str, type[Command]] = {c.NAME: c for c in get_args(EndpointCommand)}


_C = TypeVar("_C", bound=type[Command])


def register_command(*senders: Sender) -> Callable[[_C], _C]:
    """Class decorator: let `decode_command` parse an extension command defined in another
    module when one of `senders` sends it."""

    def register(cls: _C) -> _C:
        for sender in senders:
            (_FROM_CLIENT if sender == "client" else _FROM_ENDPOINT)[cls.NAME] = cls
        return cls

    return register


def decode_command(name: str, payload: bytes, *, sender: Sender) -> Command:
    """Parse the system command `name` sent by `sender`; ProtocolError names what is wrong."""
    table = _FROM_CLIENT if sender == "client" else _FROM_ENDPOINT
    cls = table.get(name)
    if cls is None:
        known = ", ".join(sorted(table))
        raise ProtocolError(
            f"unknown system command {shorten(name)} from the {sender}; expected one of {known}"
        )
    return cls.from_json(_json_payload(name, payload))
