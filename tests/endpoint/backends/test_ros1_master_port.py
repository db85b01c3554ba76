"""RosCore's port: `free_port` only says a port was free a moment ago, so a roscore whose
chosen port another process took first (here: another master, the worst case, since it
answers on the URI) moves to a new free port and answers from its own process tree; a
port that was asked for is never changed."""

from __future__ import annotations

import xmlrpc.client
from typing import Any

import pytest
from tests.ros1support import RosMaster, require_ros

from simbridge.endpoint.backends.ros1_master import _descendants
from simbridge.errors import EndpointError

pytestmark = [pytest.mark.ros1, pytest.mark.timeout(120)]


def _master_pid(uri: str) -> int:
    reply: Any = xmlrpc.client.ServerProxy(uri).getPid("/test")
    return int(reply[2])


def test_a_chosen_port_taken_by_another_master_is_replaced() -> None:
    require_ros()
    with RosMaster() as first:
        second = RosMaster()
        second.port, second.uri = first.port, first.uri  # the race, forced: it was taken
        try:
            second.start()
            assert second.port != first.port
            assert second._process is not None
            ours = {pid for pid, _ in _descendants(second._process.pid)}
            assert _master_pid(second.uri) in ours
            assert _master_pid(first.uri) not in ours
        finally:
            second.stop()


def test_a_port_asked_for_is_kept_and_a_taken_one_fails_clearly() -> None:
    require_ros()
    with RosMaster() as first:
        second = RosMaster(port=first.port)
        with pytest.raises(EndpointError, match=f"roscore on port {first.port} did not come up"):
            second.start(timeout=20)
        assert second.port == first.port
