"""Service calls in flight (sim -> ROS) and services the sim implements (ROS -> sim)."""

from __future__ import annotations

from collections.abc import Callable
from concurrent.futures import Future, InvalidStateError
from typing import Any

from simbridge.connector.codec import PayloadCodec, is_raw
from simbridge.errors import MessageError, ServiceError

__all__ = ["PendingCall", "ServiceHandler", "ServiceImpl", "resolve_future"]

ServiceHandler = Callable[[Any], Any]
"""Turns a request (object, or bytes when raw) into a response (object or bytes)."""


def resolve_future(
    future: Future[Any], result: Any = None, error: BaseException | None = None
) -> None:
    """Complete `future` unless it is already done (cancelled or timed out)."""
    if future.done():
        return
    try:
        if error is not None:
            future.set_exception(error)
        else:
            future.set_result(result)
    except InvalidStateError:
        pass


class PendingCall:
    """A request to a ROS service and the future its response completes."""

    __slots__ = ("deadline", "future", "payload", "raw", "response_type", "service", "srv_id")

    def __init__(
        self,
        service: str,
        payload: bytes,
        response_type: str | None,
        deadline: float,
    ) -> None:
        self.service = service
        self.payload = payload
        self.response_type = response_type
        """None: hand back the response bytes undecoded."""
        self.deadline = deadline
        self.srv_id = 0
        self.future: Future[Any] = Future()

    def complete(self, payload: bytes, codec: PayloadCodec) -> None:
        """Resolve with the response (decoded unless raw)."""
        if self.response_type is None:
            resolve_future(self.future, payload)
            return
        try:
            response = codec.decode(payload, self.response_type)
        except MessageError as exc:
            resolve_future(self.future, error=ServiceError(f"{self.service}: bad response: {exc}"))
            return
        resolve_future(self.future, response)

    def fail(self, text: str) -> None:
        """Resolve with ServiceError(text)."""
        resolve_future(self.future, error=ServiceError(text))


class ServiceImpl:
    """A service whose implementation is `handler`, called when ROS calls the service."""

    __slots__ = ("handler", "raw", "service", "srv_type")

    def __init__(self, service: str, srv_type: str, handler: ServiceHandler, raw: bool) -> None:
        self.service = service
        self.srv_type = srv_type
        self.handler = handler
        self.raw = raw

    def serve(self, payload: bytes, codec: PayloadCodec) -> bytes:
        """Run the handler on one serialized request; returns the serialized response."""
        if self.raw:
            response = self.handler(payload)
        else:
            response = self.handler(codec.decode(payload, codec.service_parts(self.srv_type)[0]))
        if is_raw(response):
            return codec.encode(response, self.srv_type)
        return codec.encode(response, codec.service_parts(self.srv_type)[1])
