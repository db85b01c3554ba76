"""The `action_servers` extension on a backend that cannot serve ROS 2 actions (the local
bus): not announced, and its commands sent anyway get `__error`s naming what is wrong."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from tests.endpoint.rawclient import RawClient

from simbridge.endpoint import EndpointThread
from simbridge.protocol import (
    ACTION_SERVERS_EXTENSION,
    CommandReceived,
    ErrorMessage,
    Handshake,
    ServeAction,
    ServedAccept,
    UnserveAction,
)


def _is(cls: type) -> Callable[[Any], bool]:
    return lambda e: isinstance(e, CommandReceived) and isinstance(e.command, cls)


def test_local_backend_refuses_to_serve_clearly() -> None:
    with EndpointThread() as ep:
        raw = RawClient(ep.port)
        try:
            handshake = raw.expect(_is(Handshake)).command
            assert ACTION_SERVERS_EXTENSION not in handshake.metadata["extensions"]
            raw.send(ServeAction("/fib", "test_msgs/Fibonacci").encode())
            text = raw.expect(_is(ErrorMessage)).command.text
            assert "__action_serve failed" in text
            assert "the local backend cannot serve ROS 2 actions ('/fib'" in text
            raw.send(ServedAccept(1, True).encode())
            text = raw.expect(_is(ErrorMessage)).command.text
            assert "goal 1 is not a goal of an action this client serves" in text
            raw.send(UnserveAction("/fib").encode())
            assert "'/fib' is not served" in raw.expect(_is(ErrorMessage)).command.text
            assert raw.stats()["session"]["errors_sent"] == 3
        finally:
            raw.close()
