"""One client's requests that wait for an answer, for its `ClientSession`: service calls both
ways (the client calling ROS, ROS calling a service the client implements) and parameter
sets. Each runs as a task; those in flight are bounded per client, and every one ends in
an answer or an `__error` naming it, never a hang. Each `__ros_service` has a caller of
its own in the backend (`Backend.service_client`), closed with the registration.
"""

from __future__ import annotations

import asyncio
import itertools
import logging
from collections.abc import Awaitable, Callable, Coroutine
from typing import Any, Protocol

from simbridge.endpoint.backends.base import Backend, BackendServiceClient
from simbridge.endpoint.options import EndpointOptions
from simbridge.errors import EndpointError, ServiceError, SimbridgeError
from simbridge.protocol import (
    ProtocolConnection,
    ServiceFailure,
    ServiceRequestReceived,
    SetParam,
    shorten,
)

__all__ = ["FIRST_SRV_ID", "ServiceClient", "SessionServices"]

log = logging.getLogger("simbridge.endpoint")

FIRST_SRV_ID = 1001
"""Ids of endpoint-initiated service requests start here, as in the original endpoint."""


class ServiceClient(Protocol):
    """What service calls need of the client connection they serve."""

    @property
    def peer(self) -> str:
        """The client's address, for errors and logs."""
        ...

    @property
    def closing(self) -> bool:
        """Whether the connection is going away (nothing more is sent to it)."""
        ...

    def send_control(self, frame: bytes) -> None:
        """Send a frame that must not be dropped."""

    def send_error(
        self, text: str, srv_id: int | None = None, *, goal_id: int | None = None
    ) -> None:
        """Report a failure to the client (with `srv_id`, that call's)."""


class SessionServices:
    """The calls and parameter sets of one client connection that wait for an answer.

    The client's `__ros_service` registrations come and go through `open_caller` and
    `close_caller`.
    """

    def __init__(
        self,
        client: ServiceClient,
        backend: Backend,
        options: EndpointOptions,
        loop: asyncio.AbstractEventLoop,
    ) -> None:
        self._client = client
        self._backend = backend
        self._timeout = options.service_timeout
        self._max_inflight = options.max_inflight_calls
        self._loop = loop
        self._pending: dict[int, asyncio.Future[bytes]] = {}
        self._srv_ids = itertools.count(FIRST_SRV_ID)
        self._tasks: set[asyncio.Task[None]] = set()
        self._callers: dict[str, BackendServiceClient] = {}
        """The backend's caller of each registered service."""

    # ---- the client's registrations ---------------------------------------------------

    def open_caller(self, service: str, srv_type: str) -> None:
        """`__ros_service`: a caller of `service` replaces any earlier one (SimbridgeError
        when the backend cannot make it; the earlier one is then kept)."""
        caller = self._backend.service_client(service, srv_type)
        self.close_caller(service)
        self._callers[service] = caller

    def close_caller(self, service: str) -> None:
        """The registration of `service` is gone: so is its caller (a call in flight fails)."""
        caller = self._callers.pop(service, None)
        if caller is not None:
            caller.close()

    # ---- the client calls ROS -------------------------------------------------------

    def call(self, event: ServiceRequestReceived) -> None:
        """The client calls `event.service`; the answer or an `__error` with the call's
        srv_id follows."""
        if len(self._tasks) >= self._max_inflight:
            self._client.send_error(
                f"call of {shorten(event.service)} (srv_id {event.srv_id}) refused: "
                f"{len(self._tasks)} calls already in flight (limit "
                f"{self._max_inflight}); wait for answers first",
                event.srv_id,
            )
        else:
            self._spawn(self._serve(event))

    async def _serve(self, event: ServiceRequestReceived) -> None:
        client = self._client
        caller = self._callers.get(event.service)
        if caller is None:
            client.send_error(
                f"service {shorten(event.service)} was not registered with __ros_service; "
                "register it before calling",
                event.srv_id,
            )
            return
        try:
            response = await caller.call(event.payload, timeout=self._timeout)
        except SimbridgeError as exc:
            client.send_error(
                f"call of {shorten(event.service)} (srv_id {event.srv_id}) failed: {exc}",
                event.srv_id,
            )
            return
        except Exception as exc:
            log.exception("service %s failed", event.service)
            client.send_error(f"call of {shorten(event.service)} failed: {exc!r}", event.srv_id)
            return
        client.send_control(
            ProtocolConnection.service_response(event.srv_id, event.service, response)
        )

    # ---- ROS calls the client ---------------------------------------------------------

    def handler(self, service: str) -> Callable[[bytes], Awaitable[bytes]]:
        """The backend's handler of `service`, which the client implements."""

        async def handler(request: bytes) -> bytes:
            return await self._call_client(service, request)

        return handler

    async def _call_client(self, service: str, request: bytes) -> bytes:
        client = self._client
        if client.closing:
            raise ServiceError(f"the client implementing {shorten(service)} has disconnected")
        srv_id = next(self._srv_ids)
        future: asyncio.Future[bytes] = self._loop.create_future()
        self._pending[srv_id] = future
        client.send_control(ProtocolConnection.service_request(srv_id, service, request))
        try:
            return await asyncio.wait_for(future, self._timeout)
        except TimeoutError:
            raise ServiceError(
                f"client {client.peer} did not answer {shorten(service)} within {self._timeout:g} s"
            ) from None
        finally:
            self._pending.pop(srv_id, None)

    def answered(self, srv_id: int, service: str, payload: bytes) -> None:
        """The client's `__response` to the request `srv_id`."""
        future = self._pending.pop(srv_id, None)
        if future is None:
            self._client.send_error(f"__response for unknown srv_id {srv_id} ({shorten(service)})")
        elif not future.done():
            future.set_result(payload)

    def failed(self, command: ServiceFailure) -> None:
        """The client's `__service_error`: its handler of a request failed."""
        future = self._pending.pop(command.srv_id, None)
        if future is None:
            self._client.send_error(f"__service_error for unknown srv_id {command.srv_id}")
        elif not future.done():
            future.set_exception(
                ServiceError(
                    f"the service handler in client {self._client.peer} failed: {command.text}"
                )
            )

    # ---- parameters -------------------------------------------------------------------

    def set_param(self, command: SetParam) -> None:
        """`__set_param`: the backend sets it (the ROS 1 master is a round trip away, so
        this runs as a task); EndpointError when too many requests are in flight."""
        if len(self._tasks) >= self._max_inflight:
            raise EndpointError(
                f"{shorten(command.name)} not set: {len(self._tasks)} requests already in "
                f"flight (limit {self._max_inflight}); wait for them first"
            )
        self._spawn(self._set_param(command))

    async def _set_param(self, command: SetParam) -> None:
        """A failure is an `__error` naming the parameter."""
        try:
            await self._backend.set_param(command.name, command.value)
        except SimbridgeError as exc:
            self._client.send_error(f"__set_param {shorten(command.name)} failed: {exc}")
            return
        log.info("client %s set parameter %s", self._client.peer, shorten(command.name))

    # ---- end --------------------------------------------------------------------------

    def close(self) -> None:
        """The client left: its requests to ROS are cancelled, ROS's calls to it fail, its
        callers leave the graph."""
        for future in self._pending.values():
            if not future.done():
                future.set_exception(ServiceError(f"client {self._client.peer} disconnected"))
        self._pending.clear()
        for task in list(self._tasks):
            task.cancel()
        for service in list(self._callers):
            self.close_caller(service)

    def _spawn(self, coro: Coroutine[Any, Any, None]) -> None:
        task = asyncio.ensure_future(coro)
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)
