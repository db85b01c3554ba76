"""In-process ROS-like nodes on the embedded `local` backend (no ROS install needed).

A Node publishes, subscribes, serves and calls with message objects, from any
thread. Its callbacks and service handlers run on the node's own worker thread,
so a slow handler (a motion planner, say) never stalls the endpoint's loop.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import logging
import threading
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
from simbridge.messages import MessageRegistry, WireFormat, registry_for

__all__ = ["Node", "NodePublisher"]

log = logging.getLogger("simbridge.node")


class NodePublisher:
    """Publishes message objects on one topic."""

    def __init__(self, node: Node, topic: str, msg_type: str, backend: BackendPublisher) -> None:
        self.topic, self.msg_type = topic, msg_type
        self._node, self._backend = node, backend
        self._codec = node.registry.codec(msg_type)

    def publish(self, msg: Any) -> None:
        """Serialize in the caller's thread, deliver on the bus loop."""
        payload = msg if isinstance(msg, bytes) else self._codec.encode(msg, self._node.fmt)
        self._node._on_loop(self._backend.publish, payload)


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
        self._closed = False

    def _on_loop(self, fn: Callable[..., Any], *args: Any) -> None:
        if threading.get_ident() == getattr(self.loop, "_thread_id", None):
            fn(*args)
        else:
            self.loop.call_soon_threadsafe(fn, *args)

    def _sync(self, fn: Callable[[], Any], timeout: float = 10.0) -> Any:
        if threading.get_ident() == getattr(self.loop, "_thread_id", None):
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
        return NodePublisher(self, topic, canonical, backend)

    def subscribe(self, topic: str, msg_type: str, callback: Callable[[Any], None]) -> None:
        """Call `callback(msg)` on the node's worker thread for every message on `topic`."""
        codec = self.registry.codec(msg_type)

        def deliver(payload: bytes) -> None:
            self._worker.submit(self._guard, callback, lambda: codec.decode(payload, self.fmt))

        canonical = self.registry.resolve(msg_type)
        self._handles.append(self._sync(lambda: self.bus.subscribe(topic, canonical, deliver)))

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
        if threading.get_ident() == getattr(self.loop, "_thread_id", None):
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
