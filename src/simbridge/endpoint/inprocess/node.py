"""In-process ROS-like nodes on the embedded `local` backend (no ROS install needed).

A Node publishes, subscribes, serves and calls with message objects, from any
thread. Its callbacks and service handlers run on the node's own worker thread,
so a slow handler (a motion planner, say) never stalls the endpoint's loop.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import functools
import logging
import threading
from collections import deque
from collections.abc import Callable
from typing import Any

from simbridge.endpoint.backends.base import (
    Backend,
    BackendPublisher,
    BackendServiceServer,
    BackendSubscription,
)
from simbridge.endpoint.backends.local import LocalBus
from simbridge.errors import EndpointError, ServiceError
from simbridge.messages import Codec, MessageRegistry, WireFormat, registry_for

__all__ = ["Node", "NodePublisher"]

log = logging.getLogger("simbridge.node")


class NodePublisher:
    """Publishes message objects on one topic, encoded as `fmt`; `on_loop(fn, *args)` runs
    `fn` on the bus's loop (the node's)."""

    def __init__(
        self,
        topic: str,
        msg_type: str,
        backend: BackendPublisher,
        *,
        codec: Codec,
        fmt: WireFormat,
        on_loop: Callable[..., None],
    ) -> None:
        self.topic, self.msg_type = topic, msg_type
        self._backend, self._codec, self._fmt, self._on_loop = backend, codec, fmt, on_loop

    def publish(self, msg: Any) -> None:
        """Serialize in the caller's thread, deliver on the bus loop."""
        payload = msg if isinstance(msg, bytes) else self._codec.encode(msg, self._fmt)
        self._on_loop(self._backend.publish, payload)


class _Inbox:
    """Payloads waiting for one subscription's callback: at most `size`, the oldest dropped
    (as a ROS subscriber queue does) and counted; one drain at a time on the worker."""

    def __init__(self, size: int) -> None:
        self._items: deque[bytes] = deque()
        self._size = size
        self._lock = threading.Lock()
        self._draining = False
        self.dropped = 0

    def push(self, payload: bytes) -> tuple[bool, bool]:
        """Queue `payload`; returns (a drain must be scheduled, the oldest was dropped)."""
        with self._lock:
            dropped = len(self._items) >= self._size
            if dropped:
                self._items.popleft()
                self.dropped += 1
            self._items.append(payload)
            start, self._draining = not self._draining, True
            return start, dropped

    def pop(self) -> bytes | None:
        """The next payload, or None (and the drain ends) when none is left."""
        with self._lock:
            if self._items:
                return self._items.popleft()
            self._draining = False
            return None


class Node:
    """A named participant in a LocalBus graph. Messages use the bus's protocol: ROS 1
    binary, or CDR with ROS 2 layouts (the shared registry of it unless one is given).

    It also runs on another started backend given the loop that backend runs on (say,
    `EndpointThread.loop`): on the ROS 1 backend its topics are real ROS topics of the
    endpoint's rospy node.
    """

    def __init__(
        self,
        bus: Backend,
        name: str,
        registry: MessageRegistry | None = None,
        *,
        loop: asyncio.AbstractEventLoop | None = None,
    ) -> None:
        loop = loop or (bus.loop if isinstance(bus, LocalBus) else None)
        if loop is None:
            raise EndpointError(
                f"the {bus.name} backend is not running (or its loop was not given); "
                "start its endpoint first"
            )
        self.bus, self.name = bus, name
        self.loop = loop
        self.registry = registry or registry_for(bus.protocol)
        self.fmt: WireFormat = "cdr" if bus.protocol == "ROS2" else "ros1"
        """The serialization on the bus."""
        self._worker = concurrent.futures.ThreadPoolExecutor(1, thread_name_prefix=f"node{name}")
        self._handles: list[BackendPublisher | BackendSubscription | BackendServiceServer] = []
        self._inboxes: dict[str, _Inbox] = {}
        self._closed = False

    def _in_loop(self) -> bool:
        """Whether the caller runs on the bus's loop (then calls need no hand-off)."""
        try:
            return asyncio.get_running_loop() is self.loop
        except RuntimeError:  # no loop runs in this thread
            return False

    def _on_loop(self, fn: Callable[..., Any], *args: Any) -> None:
        if self._in_loop():
            fn(*args)
        else:
            self.loop.call_soon_threadsafe(fn, *args)

    def _sync(self, fn: Callable[[], Any], timeout: float = 10.0) -> Any:
        if self._in_loop():
            return fn()

        async def run() -> Any:
            return fn()

        return asyncio.run_coroutine_threadsafe(run(), self.loop).result(timeout)

    def advertise(self, topic: str, msg_type: str, *, latch: bool = False) -> NodePublisher:
        """Start publishing `msg_type` messages on `topic`."""
        canonical = self.registry.resolve(msg_type)
        backend = self._sync(
            lambda: self.bus.advertise(topic, canonical, queue_size=10, latch=latch)
        )
        self._handles.append(backend)
        codec = self.registry.codec(canonical)
        return NodePublisher(
            topic, canonical, backend, codec=codec, fmt=self.fmt, on_loop=self._on_loop
        )

    def subscribe(
        self,
        topic: str,
        msg_type: str,
        callback: Callable[[Any], None],
        *,
        queue_size: int = 1000,
    ) -> None:
        """Call `callback(msg)` on the node's worker thread for every message on `topic`.

        At most `queue_size` messages wait for a slow callback (bursts of a flat-out sim
        fit the default); past that the oldest are dropped, counted in `dropped` and
        logged once per topic.
        """
        if queue_size < 1:
            raise EndpointError(f"queue_size {queue_size} for {topic!r}: expected at least 1")
        codec = self.registry.codec(msg_type)
        inbox = self._inboxes.setdefault(topic, _Inbox(queue_size))

        def drain() -> None:
            while (payload := inbox.pop()) is not None:
                self._guard(callback, functools.partial(codec.decode, payload, self.fmt))

        def deliver(payload: bytes) -> None:
            start, dropped = inbox.push(payload)
            if dropped and inbox.dropped == 1:
                log.warning(
                    "node %s: callback on %s is slow; dropping the oldest messages "
                    "(queue_size %d; see Node.dropped)",
                    self.name,
                    topic,
                    queue_size,
                )
            if start and not self._closed:
                self._worker.submit(drain)

        canonical = self.registry.resolve(msg_type)
        self._handles.append(self._sync(lambda: self.bus.subscribe(topic, canonical, deliver)))

    @property
    def dropped(self) -> dict[str, int]:
        """Messages dropped per subscribed topic because the callback fell behind."""
        return {topic: inbox.dropped for topic, inbox in self._inboxes.items()}

    @staticmethod
    def _guard(callback: Callable[[Any], None], make: Callable[[], Any]) -> None:
        try:
            callback(make())
        except Exception:
            log.exception("node callback failed")

    def serve(self, service: str, srv_type: str, handler: Callable[[Any], Any]) -> None:
        """Offer `service`; `handler(request) -> response` runs on the worker thread."""
        info = self.registry.service(srv_type)
        req_codec = self.registry.codec(info.request)
        resp_codec = self.registry.codec(info.response)

        def run(payload: bytes) -> bytes:
            response = handler(req_codec.decode(payload, self.fmt))
            if isinstance(response, bytes):
                return response
            return resp_codec.encode(response, self.fmt)

        async def handle(payload: bytes) -> bytes:
            future = self._worker.submit(run, payload)
            return await asyncio.wrap_future(future)

        self._handles.append(
            self._sync(lambda: self.bus.advertise_service(service, info.name, handle))
        )

    def call(self, service: str, srv_type: str, request: Any, *, timeout: float = 10.0) -> Any:
        """Call a service on the bus from a thread other than the bus loop's."""
        if self._in_loop():
            raise ServiceError("Node.call would block the bus loop; call it from another thread")
        info = self.registry.service(srv_type)
        payload = (
            request
            if isinstance(request, bytes)
            else self.registry.codec(info.request).encode(request, self.fmt)
        )
        coro = self.bus.call_service(service, info.name, payload, timeout=timeout)
        raw = asyncio.run_coroutine_threadsafe(coro, self.loop).result(timeout + 1)
        return self.registry.codec(info.response).decode(raw, self.fmt)

    def close(self) -> None:
        """Withdraw every registration and stop the worker."""
        if self._closed:
            return
        self._closed = True
        handles, self._handles = self._handles, []
        if not self.loop.is_closed():
            self._on_loop(lambda: [h.close() for h in handles])
        self._worker.shutdown(wait=False, cancel_futures=True)

    def __enter__(self) -> Node:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()
