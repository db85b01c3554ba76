"""The embedded `local` backend: an in-process ROS-like graph needing no ROS install.

Topics (latched too), services and a typed topic list, living on the endpoint's
event loop. Payloads stay serialized; subscribers get the publisher's bytes as they are.
In ROS 2 mode (`LocalBus("ROS2")`) the handshake announces ROS2, so clients send CDR
with ROS 2 layouts, and in-process nodes use them too: the ROS 2 path of a client can
be exercised without any ROS 2 install.
"""

from __future__ import annotations

import asyncio
import itertools
import logging
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Literal

from simbridge.endpoint.backends.base import (
    Backend,
    BackendPublisher,
    BackendServiceServer,
    BackendSubscription,
    MessageCallback,
    ServiceHandler,
    TopicInfo,
)
from simbridge.errors import EndpointError, ServiceError

__all__ = ["LocalBus"]

log = logging.getLogger("simbridge.endpoint.local")

MAX_PARAMS = 10_000
"""Parameters the bus holds at most; setting a new one past this is refused."""


@dataclass(slots=True)
class _Topic:
    msg_type: str
    callbacks: dict[int, MessageCallback] = field(default_factory=dict)
    fanout: tuple[MessageCallback, ...] = ()
    """Snapshot of `callbacks` for the publish hot path."""
    watchers: dict[int, Callable[[int], None]] = field(default_factory=dict)

    def subscribers_changed(self) -> None:
        self.fanout = tuple(self.callbacks.values())
        for watcher in tuple(self.watchers.values()):
            try:
                watcher(len(self.callbacks))
            except Exception:
                log.exception("subscriber-count watcher failed")

    publishers: int = 0
    latched: dict[int, bytes] = field(default_factory=dict)


@dataclass(slots=True)
class _Service:
    srv_type: str
    handler: ServiceHandler
    owner: int


class _Publisher(BackendPublisher):
    """`closed(topic)` tells the bus the publisher is gone (it forgets an unused topic)."""

    __slots__ = ("_closed", "_id", "_latch", "_state", "_topic")

    def __init__(
        self, topic: str, state: _Topic, latch: bool, pub_id: int, closed: Callable[[str], None]
    ) -> None:
        self._topic = topic
        self._state: _Topic | None = state
        self._latch = latch
        self._id = pub_id
        self._closed = closed

    def publish(self, payload: bytes | bytearray) -> None:
        payload = bytes(payload)  # subscribers and the latch keep bytes (no copy if bytes)
        state = self._state
        if state is None:
            raise EndpointError(f"publisher for {self._topic!r} is closed")
        if self._latch:
            state.latched[self._id] = payload
        for callback in state.fanout:
            try:
                callback(payload)
            except Exception:
                log.exception("subscriber callback on %s failed", self._topic)

    def watch_subscribers(self, callback: Callable[[int], None]) -> bool:
        state = self._state
        if state is None:
            return False
        state.watchers[self._id] = callback
        callback(len(state.callbacks))
        return True

    def close(self) -> None:
        state, self._state = self._state, None
        if state is not None:
            state.watchers.pop(self._id, None)
            state.publishers -= 1
            state.latched.pop(self._id, None)
            self._closed(self._topic)


class _Subscription(BackendSubscription):
    """`close` calls `unsubscribe(topic, sub_id)`, the bus's own bookkeeping."""

    __slots__ = ("_id", "_topic", "_unsubscribe")

    def __init__(self, topic: str, sub_id: int, unsubscribe: Callable[[str, int], None]) -> None:
        self._topic, self._id, self._unsubscribe = topic, sub_id, unsubscribe

    def close(self) -> None:
        self._unsubscribe(self._topic, self._id)


class _ServiceServer(BackendServiceServer):
    """`close` calls `withdraw(name, owner)`, the bus's own bookkeeping."""

    __slots__ = ("_id", "_name", "_withdraw")

    def __init__(self, name: str, owner: int, withdraw: Callable[[str, int], None]) -> None:
        self._name, self._id, self._withdraw = name, owner, withdraw

    def close(self) -> None:
        self._withdraw(self._name, self._id)


class LocalBus(Backend):
    """An in-process graph; every method must run on the loop that started it."""

    name = "local"

    def __init__(self, protocol: Literal["ROS1", "ROS2"] = "ROS1") -> None:
        if protocol not in ("ROS1", "ROS2"):
            raise EndpointError(f"protocol {protocol!r} is not one of ROS1, ROS2")
        self.protocol = protocol
        self._topics: dict[str, _Topic] = {}
        self._services: dict[str, _Service] = {}
        self._ids = itertools.count(1)
        self._params: dict[str, Any] = {}
        self.loop: asyncio.AbstractEventLoop | None = None

    async def start(self) -> None:
        self.loop = asyncio.get_running_loop()

    def _state(self, topic: str, msg_type: str) -> _Topic:
        state = self._topics.get(topic)
        if state is None:
            state = self._topics[topic] = _Topic(msg_type)
        elif state.msg_type != msg_type:
            raise EndpointError(
                f"topic {topic!r} already has type {state.msg_type!r}; "
                f"cannot use it as {msg_type!r}"
            )
        return state

    def _gc(self, topic: str) -> None:
        state = self._topics.get(topic)
        if state is not None and not state.callbacks and state.publishers <= 0:
            del self._topics[topic]

    def _unsubscribe(self, topic: str, sub_id: int) -> None:
        state = self._topics.get(topic)
        if state is not None and state.callbacks.pop(sub_id, None) is not None:
            state.subscribers_changed()
            self._gc(topic)

    def _withdraw(self, name: str, owner: int) -> None:
        service = self._services.get(name)
        if service is not None and service.owner == owner:
            del self._services[name]

    def advertise(
        self, topic: str, msg_type: str, *, queue_size: int, latch: bool
    ) -> BackendPublisher:
        state = self._state(topic, msg_type)
        state.publishers += 1
        return _Publisher(topic, state, latch, next(self._ids), self._gc)

    def subscribe(
        self, topic: str, msg_type: str, callback: MessageCallback
    ) -> BackendSubscription:
        state = self._state(topic, msg_type)
        sub_id = next(self._ids)
        state.callbacks[sub_id] = callback
        state.subscribers_changed()
        for payload in tuple(state.latched.values()):
            callback(payload)
        return _Subscription(topic, sub_id, self._unsubscribe)

    async def call_service(
        self, service: str, srv_type: str, request: bytes, *, timeout: float
    ) -> bytes:
        entry = self._services.get(service)
        if entry is None:
            known = ", ".join(sorted(self._services)) or "none"
            raise ServiceError(f"service {service!r} has no provider (services offered: {known})")
        if entry.srv_type != srv_type:
            raise ServiceError(f"service {service!r} has type {entry.srv_type!r}, not {srv_type!r}")
        try:
            return await asyncio.wait_for(entry.handler(request), timeout)
        except TimeoutError:
            raise ServiceError(f"service {service!r} did not answer within {timeout:g} s") from None
        except ServiceError:
            raise
        except Exception as exc:
            raise ServiceError(f"service {service!r} failed: {exc}") from exc

    def advertise_service(
        self, service: str, srv_type: str, handler: ServiceHandler
    ) -> BackendServiceServer:
        owner = next(self._ids)
        self._services[service] = _Service(srv_type, handler, owner)
        return _ServiceServer(service, owner, self._withdraw)

    def topics(self) -> list[TopicInfo]:
        return [TopicInfo(name, state.msg_type) for name, state in sorted(self._topics.items())]

    async def set_param(self, name: str, value: Any) -> None:
        """Keep `value` as parameter `name` (a plain dict: the bus has no master)."""
        if name not in self._params and len(self._params) >= MAX_PARAMS:
            raise EndpointError(
                f"parameter {name!r} not set: the bus holds {MAX_PARAMS} parameters (the limit)"
            )
        self._params[name] = value

    def get_param(self, name: str, default: Any = None) -> Any:
        """Parameter `name` as last set by a client, or `default`."""
        return self._params.get(name, default)

    def services(self) -> dict[str, str]:
        """Every offered service and its type."""
        return {name: entry.srv_type for name, entry in sorted(self._services.items())}
