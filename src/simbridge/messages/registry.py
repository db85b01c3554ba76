"""The message registry: every known type, its md5, definition text, codec and converters."""

from __future__ import annotations

import difflib
import hashlib
import json
import re
import threading
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Literal, NoReturn

import msgpack
import yaml
from rosbags.interfaces import Nodetype
from rosbags.typesys import Stores, TypesysError, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

from simbridge.errors import MessageError, UnknownMessageTypeError

from .codec import Codec, WireFormat
from .construct import Builder
from .export import Exporter
from .lazy import MAX_DEFINITION_BYTES, MAX_DEFINITION_FIELDS, PendingSources
from .loader import InterfaceSources, load_interface_dirs, split_sections
from .names import parse_type_name, store_name
from .rostime import ROS1_TIME_RANGES, ROS2_TIME_RANGES, use_ros1_layout
from .schema import MessageSchema, build_schema, canonical_of
from .service_info import ServiceInfo

__all__ = [
    "ROS2_STORE",
    "SHIPPED_DEFINITIONS",
    "MessageRegistry",
    "default_registry",
    "registry_for",
    "ros2_registry",
]

SHIPPED_DEFINITIONS = Path(__file__).parent / "definitions"
"""Definitions shipped with simbridge (moveit_msgs subset, niryo_moveit, tf2_msgs, std_srvs ...)."""

ROS2_STORE = Stores.ROS2_JAZZY
"""The ROS 2 distribution whose layouts ROS 2 mode uses (Jazzy, the current LTS)."""

_TIME_KEYS = {"time": "builtin_interfaces/msg/Time", "duration": "builtin_interfaces/msg/Duration"}
_ALIASES = {"Header": "std_msgs/Header"}
_SEPARATOR = "=" * 80 + "\n"
_MAX_MATCHED_NAME = 256
"""Longest name close matches are looked for."""
_CONSTANT_LINE = re.compile(
    r"^\s*(?P<type>bool|byte|char|u?int(?:8|16|32|64)|float(?:32|64)|string)\s+"
    r"(?P<name>[A-Za-z][A-Za-z0-9_]*)\s*=(?P<value>.*)$"
)


class MessageRegistry:
    """Known ROS 1 message and service types, backed by one rosbags Typestore.

    Names are accepted as `pkg/Type` (canonical) or `pkg/msg/Type`; services as
    `pkg/Srv` or `pkg/srv/Srv`, their parts as `pkg/SrvRequest` / `pkg/SrvResponse`.
    """

    def __init__(self, *, store: Stores = Stores.ROS1_NOETIC, shipped: bool = True) -> None:
        """Start from rosbags' `store` (ROS 1 noetic; a ROS 2 store gives ROS 2 layouts,
        e.g. Header without seq, for CDR peers), plus the shipped definitions."""
        self._store = get_typestore(store)
        use_ros1_layout(self._store)  # ROS 1 binary: uint32 time secs, int32 duration nsecs
        self.protocol: Literal["ROS1", "ROS2"] = "ROS1" if store == Stores.ROS1_NOETIC else "ROS2"
        """The ROS generation of the store's layouts ("ROS2" for every store but noetic)."""
        self.wire_format: WireFormat = "ros1" if self.protocol == "ROS1" else "cdr"
        """The serialization encode/decode use by default: ROS 1 binary or CDR."""
        self._ros2_names: dict[str, str] = {}
        self._lock = threading.RLock()
        self._texts: dict[str, str] = {}
        self._constant_texts: dict[str, dict[str, str]] = {}
        self._services: dict[str, tuple[str, str]] = {}
        self._schemas: dict[str, MessageSchema] = {}
        self._md5s: dict[str, str] = {}
        self._codecs: dict[str, Codec] = {}
        self._pending = PendingSources()
        ros1 = self.protocol == "ROS1"
        self._builder = Builder(self, ROS1_TIME_RANGES if ros1 else ROS2_TIME_RANGES)
        self._exporter = Exporter(self.schema, ros2_time=not ros1)
        if shipped:
            self._load_shipped(strict=ros1)

    # -- adding types -----------------------------------------------------------------------

    def load_packages(self, *paths: str | Path, lazy: bool = False) -> list[str]:
        """Add the packages under `paths` (package dirs or dirs of packages); returns new types.

        With `lazy`, files are read now but each type is parsed on first use (startup stays
        fast with large user types); a bad definition is then reported at that use.
        """
        sources = load_interface_dirs(*paths, ros2=self.protocol == "ROS2")
        if not lazy:
            return self.add_sources(sources)
        with self._lock:
            self._pending.add(sources)
        return sorted(sources.messages)

    def _load_pending(self, found: InterfaceSources | None) -> bool:
        """Parse deferred definitions now (first use); False when there were none."""
        if found is None:
            return False
        self.add_sources(found)
        return True

    def _load_shipped(self, *, strict: bool) -> None:
        """Shipped packages are written for noetic; other stores get those whose
        dependencies they have (e.g. no roscpp/Logger in ROS 2)."""
        if strict:
            self.load_packages(SHIPPED_DEFINITIONS)
            return
        pending = sorted(p for p in SHIPPED_DEFINITIONS.iterdir() if p.is_dir())
        progress = True
        while pending and progress:
            progress = False
            for package in list(pending):
                try:
                    self.load_packages(package)
                except MessageError:
                    continue
                pending.remove(package)
                progress = True

    def add_message(self, name: str, text: str) -> str:
        """Add one message type from its `.msg` text; returns its canonical name."""
        canonical = self._parse_new(name)
        self.add_sources(InterfaceSources(messages={canonical: text}))
        return canonical

    def add_service(self, name: str, text: str) -> ServiceInfo:
        """Add one service type from its `.srv` text (request `---` response)."""
        canonical = self._parse_new(name)
        request, response = split_sections(text, 2, canonical)
        sources = InterfaceSources()
        package, _, srv = canonical.partition("/")
        sources.add_service(canonical, request, response, f"{package}/srv/{srv}")
        self.add_sources(sources)
        return self.service(canonical)

    def add_sources(self, sources: InterfaceSources) -> list[str]:
        """Register parsed sources atomically: nothing is added if any type is invalid."""
        with self._lock:
            typs: dict[str, Any] = {}
            for canonical, text in sources.messages.items():
                _check_field_lines(canonical, text)
                try:
                    typs.update(get_types_from_msg(text, store_name(canonical)))
                except TypesysError as exc:
                    msg = f"invalid definition of {canonical}: {exc}"
                    raise MessageError(msg) from exc
            self._check_references(typs)
            try:
                self._store.register(typs)
            except TypesysError as exc:
                raise MessageError(str(exc)) from exc
            for canonical, text in sources.messages.items():
                self._texts[canonical] = text
                self._constant_texts[canonical] = _constant_texts(text)
            self._services.update(sources.services)
            self._ros2_names.update(sources.ros2_names)
            return sorted(sources.messages)

    def _parse_new(self, name: str) -> str:
        parsed = parse_type_name(name)
        if parsed is None:
            msg = f"invalid type name {name!r}; expected pkg/Type"
            raise MessageError(msg)
        return parsed.canonical

    def _check_references(self, typs: Mapping[str, Any]) -> None:
        self._check_unknown_references(typs)
        _check_no_cycles(typs)

    def _check_unknown_references(self, typs: Mapping[str, Any]) -> None:
        for key, (_, fields) in typs.items():
            for field_name, desc in fields:
                sub = desc[1][0] if desc[0] in (Nodetype.ARRAY, Nodetype.SEQUENCE) else desc
                if sub[0] != Nodetype.NAME:
                    continue
                ref = sub[1]
                if ref not in typs and ref not in self._store.fielddefs:
                    owner, missing = canonical_of(key), canonical_of(ref)
                    msg = f"{owner}.{field_name} uses unknown message type {missing}"
                    close = self._close_matches(missing)
                    raise MessageError(
                        msg + (f"; did you mean {', '.join(close)}?" if close else "")
                    )

    # -- names ------------------------------------------------------------------------------

    def names(self) -> list[str]:
        """Every message type, canonical and sorted."""
        loaded = (canonical_of(k) for k in self._store.fielddefs if k not in _TIME_KEYS.values())
        return sorted({*loaded, *self._pending.messages})

    def service_names(self) -> list[str]:
        """Every service type, canonical and sorted."""
        return sorted({*self._services, *self._pending.services})

    def has(self, name: str) -> bool:
        """Whether `name` is a known message type."""
        return self._lookup(name) is not None

    def has_service(self, name: str) -> bool:
        """Whether `name` is a known service type."""
        return self._service_lookup(name) is not None

    def ros2_name(self, name: str) -> str:
        """The ROS 2 (rosidl) name of a message or service type: `pkg/msg/Type`,
        `pkg/srv/Srv`, `pkg/srv/Srv_Request`, `pkg/action/Act_Goal`, ..."""
        canonical = self._lookup(name) or self._service_lookup(name)
        if canonical is None:
            self._unknown(name, "message or service")
        return self._ros2_names.get(canonical) or store_name(canonical)

    def resolve(self, name: str) -> str:
        """The canonical `pkg/Type` of a message type; UnknownMessageTypeError if unknown."""
        canonical = self._lookup(name)
        if canonical is None:
            self._unknown(name, "message")
        return canonical

    def _lookup(self, name: str) -> str | None:
        if name in self._schemas:
            return name
        name = _ALIASES.get(name, name)
        parsed = parse_type_name(name) if isinstance(name, str) else None
        if parsed is None:
            return None
        canonical = parsed.canonical
        if store_name(canonical) in self._store.fielddefs:
            return canonical
        if self._pending.messages and canonical in self._pending.messages:
            with self._lock:
                self._load_pending(self._pending.take_message(canonical))
            return canonical if store_name(canonical) in self._store.fielddefs else None
        return None

    def _service_lookup(self, name: str) -> str | None:
        parsed = parse_type_name(name) if isinstance(name, str) else None
        if parsed is None:
            return None
        canonical = parsed.canonical
        if canonical not in self._services and canonical in self._pending.services:
            with self._lock:
                self._load_pending(self._pending.take_service(canonical))
        return canonical if canonical in self._services else None

    def _unknown(self, name: str, kind: str) -> NoReturn:
        close = self._close_matches(str(name))
        hint = f"; did you mean {', '.join(close)}?" if close else ""
        parsed = parse_type_name(name) if isinstance(name, str) else None
        if parsed is None:
            msg = f"unknown {kind} type {name!r}{hint} (names look like pkg/Type)"
        elif parsed.package not in self.packages():
            msg = (
                f"unknown {kind} type {name!r}: package {parsed.package!r} is unknown{hint or '.'} "
                "Load the package's .msg/.srv files with --msg-path DIR (a package directory "
                "or a directory of packages; MessageRegistry.load_packages in Python)"
            )
        else:
            msg = f"unknown {kind} type {name!r}: {parsed.package} has no {parsed.name!r}{hint}"
        raise UnknownMessageTypeError(msg)

    def packages(self) -> list[str]:
        """Every package with a known message or service type, sorted."""
        found = {name.partition("/")[0] for name in (*self.names(), *self._services)}
        return sorted(found)

    def _close_matches(self, name: str) -> list[str]:
        if len(name) > _MAX_MATCHED_NAME:
            return []  # difflib's cost grows with the name: no suggestions for absurd ones
        candidates = [*self.names(), *self._services]
        by_lower = {c.lower(): c for c in candidates}
        found = difflib.get_close_matches(name.lower(), list(by_lower), n=5, cutoff=0.6)
        return [by_lower[f] for f in found]

    # -- per-type facts ---------------------------------------------------------------------

    def schema(self, name: str) -> MessageSchema:
        """The field layout of message type `name`."""
        cached = self._schemas.get(name)
        if cached is not None:
            return cached
        canonical = self.resolve(name)
        schema = self._schemas.get(canonical)
        if schema is None:
            schema = build_schema(canonical, self._store.fielddefs[store_name(canonical)])
            self._schemas[canonical] = schema
        return schema

    def msg_class(self, name: str) -> type[Any]:
        """The rosbags dataclass for `name` (`time` and `duration` give the builtin classes)."""
        key = _TIME_KEYS.get(name) or store_name(self.resolve(name))
        return self._store.types[key]

    @property
    def typestore(self) -> Typestore:
        """The underlying rosbags Typestore (shared; do not register conflicting types)."""
        return self._store

    def md5(self, name: str) -> str:
        """genmsg's md5sum of a message type, or of a service type when `name` is a service."""
        if self._lookup(name) is None and self._service_lookup(name) is not None:
            return self.service(name).md5
        canonical = self.resolve(name)
        cached = self._md5s.get(canonical)
        if cached is None:
            text = self._md5_text(canonical)
            cached = self._md5s[canonical] = hashlib.md5(text.encode()).hexdigest()
        return cached

    def _md5_text(self, canonical: str) -> str:
        schema = self.schema(canonical)
        consts = self._constant_texts.get(canonical, {})
        lines = [f"{c.type} {c.name}={consts.get(c.name, c.value)}" for c in schema.constants]
        for spec in schema.fields:
            if spec.is_message:
                lines.append(f"{self.md5(spec.type)} {spec.name}")
            else:
                lines.append(f"{spec.type_text} {spec.name}")
        return "\n".join(lines)

    def service(self, name: str) -> ServiceInfo:
        """The service type `name` (`pkg/Srv` or `pkg/srv/Srv`) with its genmsg md5."""
        canonical = self._service_lookup(name)
        if canonical is None:
            self._unknown(name, "service")
        request, response = self._services[canonical]
        text = self._md5_text(request) + self._md5_text(response)
        digest = hashlib.md5(text.encode()).hexdigest()
        return ServiceInfo(canonical, request, response, digest)

    def text(self, name: str) -> str:
        """The `.msg` text of one type: the source file when loaded from one, else generated."""
        canonical = self.resolve(name)
        source = self._texts.get(canonical)
        if source is not None:
            return source
        schema = self.schema(canonical)
        lines = [f"{c.type} {c.name}={c.value}\n" for c in schema.constants]
        lines += [f"{spec.type_text} {spec.name}\n" for spec in schema.fields]
        return "".join(lines)

    def dependencies(self, name: str) -> list[str]:
        """Every message type `name` embeds, depth-first in declaration order (like genmsg)."""
        found: list[str] = []

        def visit(current: str) -> None:
            for spec in self.schema(current).fields:
                if spec.is_message and spec.type not in found:
                    found.append(spec.type)
                    visit(spec.type)

        visit(self.resolve(name))
        return found

    def definition(self, name: str) -> str:
        """The full definition (rospy `_full_text`, TCPROS `message_definition`)."""
        canonical = self.resolve(name)
        parts = [self.text(canonical), "\n"]
        for dep in self.dependencies(canonical):
            parts += [_SEPARATOR, f"MSG: {dep}\n", self.text(dep), "\n"]
        return "".join(parts)[:-1]

    def show(self, name: str) -> str:
        """`rosmsg show` / `rossrv show` text: fields with nested types indented."""
        if self._lookup(name) is None and self._service_lookup(name) is not None:
            info = self.service(name)
            return self._show(info.request, "") + "---\n" + self._show(info.response, "")
        return self._show(self.resolve(name), "")

    def _show(self, canonical: str, indent: str) -> str:
        schema = self.schema(canonical)
        consts = self._constant_texts.get(canonical, {})
        lines = [
            f"{indent}{c.type} {c.name}={consts.get(c.name, c.value)}\n" for c in schema.constants
        ]
        for spec in schema.fields:
            lines.append(f"{indent}{spec.type_text} {spec.name}\n")
            if spec.is_message:
                lines.append(self._show(spec.type, indent + "  "))
        return "".join(lines)

    # -- construction and conversion --------------------------------------------------------

    def new(self, name: str, /, **fields: Any) -> Any:
        """A message with every field zero/empty, then `fields` applied as in from_dict."""
        if not fields:
            return self._builder.default(self.resolve(name))
        return self._builder.from_dict(self.resolve(name), fields)

    def from_dict(self, name: str, data: object) -> Any:
        """Build a message from a (partial) mapping or positional list; MessageError if invalid."""
        return self._builder.from_dict(self.resolve(name), data)

    def to_dict(self, msg: object) -> dict[str, Any]:
        """Plain data: nested dicts, lists, bytes for uint8[]/char[], time as {secs, nsecs}."""
        return self._exporter.to_dict(msg)

    def to_json(self, msg: object) -> str:
        """Strict JSON text, rosbridge style: uint8[]/char[] as base64 strings, NaN and
        +-Infinity as null (read back as NaN)."""
        return self._exporter.to_json(msg)

    def from_json(self, name: str, text: str | bytes) -> Any:
        """Parse JSON text into message `name` (base64 strings accepted for uint8[])."""
        try:
            data = json.loads(text)
        except (ValueError, UnicodeDecodeError) as exc:
            raise MessageError(f"invalid JSON for {name}: {exc}") from exc
        return self.from_dict(name, data)

    def to_msgpack(self, msg: object) -> bytes:
        """MessagePack bytes."""
        return self._exporter.to_msgpack(msg)

    def from_msgpack(self, name: str, data: bytes) -> Any:
        """Parse MessagePack bytes into message `name`."""
        try:
            obj = msgpack.unpackb(data, raw=False)
        except Exception as exc:
            raise MessageError(f"invalid MessagePack for {name}: {exc}") from exc
        return self.from_dict(name, obj)

    def from_yaml(self, name: str, text: str) -> Any:
        """Parse `rostopic pub`-style YAML: a mapping, a positional list, or a bare value
        for a one-field message (`"hello"` for std_msgs/String); empty text gives defaults."""
        try:
            data = yaml.safe_load(text)
        except yaml.YAMLError as exc:
            raise MessageError(f"invalid YAML for {name}: {exc}") from exc
        schema = self.schema(name)
        if data is None:
            data = {}
        elif not isinstance(data, dict | list) and len(schema.fields) == 1:
            data = {schema.fields[0].name: data}
        return self.from_dict(name, data)

    # -- binary -----------------------------------------------------------------------------

    def codec(self, name: str) -> Codec:
        """The cached codec of `name`: use it directly on hot paths."""
        codec = self._codecs.get(name)
        if codec is None:
            canonical = self.resolve(name)
            codec = self._codecs.get(canonical)
            if codec is None:
                codec = Codec(self._store, store_name(canonical), canonical)
                self._codecs[canonical] = codec
            self._codecs[name] = codec
        return codec

    def encode(self, msg: object, name: str | None = None, fmt: WireFormat | None = None) -> bytes:
        """Serialize `msg` (type taken from the message when `name` is None) in `fmt`
        (the registry's `wire_format` unless given)."""
        if name is None:
            name = getattr(msg, "__msgtype__", None)  # `pkg/msg/Type`, a valid spelling
            if not isinstance(name, str):
                raise MessageError(f"not a message object: {type(msg).__name__}")
        return self.codec(name).encode(msg, fmt or self.wire_format)

    def decode(
        self, data: bytes | bytearray | memoryview, name: str, fmt: WireFormat | None = None
    ) -> Any:
        """Deserialize one `name` message (in the registry's `wire_format` unless `fmt`
        is given); malformed bytes raise MessageError."""
        return self.codec(name).decode(data, fmt or self.wire_format)

    def transcode(
        self, data: bytes | bytearray | memoryview, name: str, src: WireFormat, dst: WireFormat
    ) -> bytes:
        """Re-encode serialized bytes from one wire format to another (the same format
        comes back as it is, checked, except an empty type's CDR, in ROS 2's spelling)."""
        if src == dst:
            self.decode(data, name, src)
            return self.codec(name).ros2_cdr(data) if src == "cdr" else bytes(data)
        return self.encode(self.decode(data, name, src), name, dst)


def _message_refs(fields: Any) -> list[str]:
    refs = []
    for _, desc in fields:
        sub = desc[1][0] if desc[0] in (Nodetype.ARRAY, Nodetype.SEQUENCE) else desc
        if sub[0] == Nodetype.NAME:
            refs.append(sub[1])
    return refs


def _check_no_cycles(typs: Mapping[str, Any]) -> None:
    """Refuse a type that contains itself (directly or through others): genmsg cannot give
    it an md5sum, and building a default value would never end."""
    refs = {key: _message_refs(fields) for key, (_, fields) in typs.items()}
    done: set[str] = set()
    for root in refs:
        if root in done:
            continue
        path: list[str] = []
        on_path: set[str] = set()
        stack: list[tuple[str, int]] = [(root, 0)]
        while stack:
            node, index = stack.pop()
            if index == 0:
                path.append(node)
                on_path.add(node)
            children = refs.get(node, [])
            if index < len(children):
                stack.append((node, index + 1))
                child = children[index]
                if child in on_path:
                    cycle = [*path[path.index(child) :], child]
                    chain = " -> ".join(canonical_of(c) for c in cycle)
                    msg = (
                        f"{canonical_of(child)} is recursive ({chain}); ROS message types "
                        "cannot contain themselves"
                    )
                    raise MessageError(msg)
                if child not in done and child in refs:
                    stack.append((child, 0))
            else:
                path.pop()
                on_path.discard(node)
                done.add(node)


def _check_field_lines(canonical: str, text: str) -> None:
    """Reject ROS 2-only syntax rosbags would accept, such as field default values, and
    definitions too big to parse in bounded time."""
    if len(text) > MAX_DEFINITION_BYTES:
        msg = (
            f"definition of {canonical} is {len(text):,} bytes; at most "
            f"{MAX_DEFINITION_BYTES:,} are accepted"
        )
        raise MessageError(msg)
    lines = sum(1 for line in text.splitlines() if line.split("#", 1)[0].strip())
    if lines > MAX_DEFINITION_FIELDS:
        msg = (
            f"definition of {canonical} has {lines:,} fields and constants; at most "
            f"{MAX_DEFINITION_FIELDS:,} are accepted"
        )
        raise MessageError(msg)
    for number, line in enumerate(text.splitlines(), start=1):
        if "=" in line:
            continue
        tokens = line.split("#", 1)[0].split()
        if tokens and len(tokens) != 2:
            msg = f"invalid definition of {canonical}, line {number}: {line.strip()!r}"
            raise MessageError(msg + " (expected `type name` or `type NAME=value`)")


def _constant_texts(text: str) -> dict[str, str]:
    """Constant values exactly as written (genmsg hashes the text, not the parsed value)."""
    found: dict[str, str] = {}
    for line in text.splitlines():
        match = _CONSTANT_LINE.match(line)
        if match is None:
            continue
        value = match["value"]
        if match["type"] != "string":
            value = value.split("#", 1)[0]
        found[match["name"]] = value.strip()
    return found


_shared: dict[str, MessageRegistry] = {}
_shared_lock = threading.Lock()


def registry_for(protocol: Literal["ROS1", "ROS2"]) -> MessageRegistry:
    """The shared registry of one ROS generation (noetic or ROS2_STORE layouts, plus
    the shipped definitions), built on first use."""
    found = _shared.get(protocol)
    if found is None:
        with _shared_lock:
            found = _shared.get(protocol)
            if found is None:
                store = Stores.ROS1_NOETIC if protocol == "ROS1" else ROS2_STORE
                found = _shared[protocol] = MessageRegistry(store=store)
    return found


def default_registry() -> MessageRegistry:
    """The shared ROS 1 registry (noetic + shipped definitions), built on first use."""
    return registry_for("ROS1")


def ros2_registry() -> MessageRegistry:
    """The shared ROS 2 registry (Jazzy layouts + shipped definitions): Header without
    seq, CameraInfo with d/k/r/p, actions as rosidl expands them."""
    return registry_for("ROS2")
