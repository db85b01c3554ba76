"""Message objects from one registry's layouts to another's (ROS 1 noetic <-> ROS 2).

The two generations differ in a few fields: Header lost `seq`, CameraInfo's `D K R P`
became `d k r p`. A Translator maps fields by name (then case-insensitively), drops
what the target lacks and defaults what the source lacks. Types whose layouts match
field for field are passed through as they are (a codec accepts a same-named class of
another registry), so only the parts that differ are rebuilt: an Image gets a new
header, while its pixel buffer is shared, not copied. A message already of the target's
class (built for it: live-label detections, whose layouts differ beyond renames) passes as it is.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from simbridge.errors import MessageError

from .schema import FieldSpec, canonical_of

if TYPE_CHECKING:
    from .registry import MessageRegistry

__all__ = ["Translator"]

_Convert = Callable[[Any], Any]


class Translator:
    """Converts message objects laid out as in `src` into `dst`'s classes."""

    def __init__(self, src: MessageRegistry, dst: MessageRegistry) -> None:
        self.src, self.dst = src, dst
        self._plans: dict[str, _Convert | None] = {}
        self._dst_classes: dict[str, type[Any]] = {}
        self._lock = threading.RLock()

    def translate(self, msg: Any) -> Any:
        """`msg` in `dst`'s layout (the same object when the layouts already agree or `msg`
        is of `dst`'s class already)."""
        msgtype = getattr(msg, "__msgtype__", None)
        if not isinstance(msgtype, str):
            raise MessageError(f"not a message object: {type(msg).__name__}")
        name = canonical_of(msgtype)
        cls = self._dst_classes.get(name)
        if cls is None:
            cls = self._dst_classes[name] = self.dst.msg_class(name)
        if type(msg) is cls:
            return msg
        plan = self._plan(name)
        return msg if plan is None else plan(msg)

    def _plan(self, name: str) -> _Convert | None:
        """How to convert one type; None when its layouts agree (cached per type)."""
        try:
            return self._plans[name]
        except KeyError:
            pass
        with self._lock:
            if name not in self._plans:
                self._plans[name] = self._build(name)
            return self._plans[name]

    def _build(self, name: str) -> _Convert | None:
        src_fields = {f.name: f for f in self.src.schema(name).fields}
        by_lower = {f.name.lower(): f for f in src_fields.values()}
        dst_schema = self.dst.schema(name)
        steps: list[tuple[str, str | None, _Convert | None]] = []
        same = [f.name for f in dst_schema.fields] == list(src_fields)
        for spec in dst_schema.fields:
            source = src_fields.get(spec.name) or by_lower.get(spec.name.lower())
            if source is None:
                steps.append((spec.attr, None, None))
                continue
            if source.type != spec.type or source.array != spec.array:
                msg = f"{name}.{spec.name} is {source.type_text} in one layout, {spec.type_text}"
                raise MessageError(msg)
            convert = self._field(spec)
            same = same and convert is None and source.attr == spec.attr
            steps.append((spec.attr, source.attr, convert))
        if same:
            return None
        cls, builder = self.dst.msg_class(name), self.dst.new

        def convert_message(msg: Any) -> Any:
            values = {}
            for attr, src_attr, convert in steps:
                if src_attr is None:
                    values[attr] = getattr(builder(name), attr)
                    continue
                value = getattr(msg, src_attr)
                values[attr] = value if convert is None else convert(value)
            return cls(**values)

        return convert_message

    def _field(self, spec: FieldSpec) -> _Convert | None:
        """Conversion of one field's value; None when it is taken as it is."""
        element: _Convert
        if spec.type in ("time", "duration"):
            cls = self.dst.msg_class(spec.type)
            element = lambda value: cls(sec=value.sec, nanosec=value.nanosec)  # noqa: E731
        elif spec.is_message:
            plan = self._plan(spec.type)
            if plan is None:
                return None
            element = plan
        else:
            return None
        if spec.array:
            return lambda values: [element(v) for v in values]
        return element
