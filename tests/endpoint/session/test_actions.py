"""The `actions` extension on a backend without ROS 2 actions (the local bus): not announced,
and a goal sent anyway is refused with an `__error` carrying its goal id."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from tests.endpoint.rawclient import RawClient

from simbridge.endpoint import EndpointThread
from simbridge.protocol import (
    ACTIONS_EXTENSION,
    ActionCancel,
    ActionGoal,
    ActionServerQuery,
    ActionServerReply,
    CommandReceived,
    ErrorMessage,
    Handshake,
    WarnMessage,
)


def _is(cls: type) -> Callable[[Any], bool]:
    return lambda e: isinstance(e, CommandReceived) and isinstance(e.command, cls)


def test_local_backend_refuses_goals_clearly() -> None:
    with EndpointThread() as ep:
        raw = RawClient(ep.port)
        try:
            handshake = raw.expect(_is(Handshake)).command
            assert ACTIONS_EXTENSION not in handshake.metadata["extensions"]
            raw.send(ActionGoal(9, "/fibonacci", "test_msgs/Fibonacci", b"\0\1\0\0").encode())
            error = raw.expect(_is(ErrorMessage)).command
            assert error.goal_id == 9
            assert "goal 9 for '/fibonacci'" in error.text
            assert "local backend has no ROS 2 actions" in error.text
            raw.send(ActionServerQuery("/fibonacci", "test_msgs/Fibonacci").encode())
            assert "no ROS 2 actions" in raw.expect(_is(ErrorMessage)).command.text
            assert raw.expect(_is(ActionServerReply)).command == ActionServerReply(
                "/fibonacci", False
            )
            raw.send(ActionCancel(9).encode())
            warn = raw.expect(_is(WarnMessage)).command
            assert "goal 9 is not in flight" in warn.text
            stats = raw.stats()["session"]
            assert (stats["goals_sent"], stats["goals_refused"]) == (1, 1)
        finally:
            raw.close()
