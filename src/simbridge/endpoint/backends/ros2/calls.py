"""Calls of ROS 2 services for the endpoint's clients: one rclpy client per registration.

rclpy has no raw mode for services, so a request is decoded into the service's Request
class and the response encoded back (`cdr`: an empty type in each side's spelling).
A TCP client's `__ros_service` gets a client of its own, destroyed when the registration
is removed or the TCP client leaves, so the graph shows no caller that is gone.
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Callable
from typing import Any

from simbridge.endpoint.backends.base import BackendServiceClient
from simbridge.endpoint.backends.loop_calls import call_soon_from_thread
from simbridge.endpoint.backends.ros2.cdr import from_client, to_client
from simbridge.errors import EndpointError, ServiceError

__all__ = ["Ros2ServiceClient"]

_log = logging.getLogger(__name__)


class Ros2ServiceClient(BackendServiceClient):
    """An rclpy client of `service`; calls and close() run on the event loop."""

    def __init__(
        self,
        node: Any,
        loop: asyncio.AbstractEventLoop,
        service: str,
        srv_type: str,
        cls: Any,
        *,
        discovery_wait: float,
        on_close: Callable[[Ros2ServiceClient], None],
    ) -> None:
        try:
            self._client = node.create_client(cls, service)
        except Exception as exc:
            raise EndpointError(f"cannot create a client for {service!r}: {exc}") from exc
        self._node = node
        self._loop = loop
        self._service = service
        self._srv_type = srv_type
        self._cls = cls
        self._discovery_wait = discovery_wait
        self._on_close = on_close
        self._waiting: set[asyncio.Future[Any]] = set()
        """Answers of calls in flight, failed by close()."""
        self.closed = False

    async def call(self, request: bytes, *, timeout: float) -> bytes:
        """Wait (discovery_wait at most) for a server, call it and encode its response;
        ServiceError when none is found, it does not answer in time, or the request is
        not CDR of the service's request type."""
        service, srv_type = self._service, self._srv_type
        try:
            decoded = from_client(request, self._cls.Request)
        except Exception as exc:
            raise ServiceError(
                f"request for {service!r} is not a CDR {srv_type} request: {exc}"
            ) from exc
        wait = min(timeout, self._discovery_wait)
        deadline = time.monotonic() + wait
        while not self._ready():
            if time.monotonic() >= deadline:
                raise ServiceError(
                    f"no ROS 2 server for {service!r} [{srv_type}] (none found within {wait:g} s)"
                )
            await asyncio.sleep(0.01)
        answer: asyncio.Future[Any] = self._loop.create_future()
        pending = self._client.call_async(decoded)

        def settle(done: Any) -> None:
            if answer.done():
                return
            error = done.exception()
            if error is not None:
                answer.set_exception(ServiceError(f"service {service!r} failed: {error}"))
            else:
                answer.set_result(done.result())

        pending.add_done_callback(lambda done: call_soon_from_thread(self._loop, settle, done))
        self._waiting.add(answer)
        try:
            response = await asyncio.wait_for(answer, timeout)
        except TimeoutError as exc:
            self._forget(pending)
            raise ServiceError(f"service {service!r} did not answer within {timeout:g} s") from exc
        finally:
            self._waiting.discard(answer)
        return to_client(response)

    def _ready(self) -> bool:
        if self.closed:
            raise ServiceError(f"the client of {self._service!r} was closed")
        return bool(self._client.service_is_ready())

    def _forget(self, pending: Any) -> None:
        if not self.closed:
            self._client.remove_pending_request(pending)

    def close(self) -> None:
        """Destroy the rclpy client; calls in flight fail with ServiceError."""
        if self.closed:
            return
        self.closed = True
        for answer in self._waiting:
            if not answer.done():
                answer.set_exception(
                    ServiceError(
                        f"call of {self._service!r} abandoned: its registration was removed "
                        "or its client left"
                    )
                )
        self._waiting.clear()
        try:
            self._node.destroy_client(self._client)
        except Exception as exc:  # the node may already be gone
            _log.debug("destroying the client of %s: %s", self._service, exc)
        self._on_close(self)
        _log.info("stopped calling %s", self._service)
