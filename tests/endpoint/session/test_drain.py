"""A client's publishers are drained before they close (`endpoint.session.drain`): on the
local backend a client that publishes N and leaves at once has N delivered; a drain runs
in the background (other clients are served meanwhile), the publisher closes after it,
and a bound that is hit is counted in `__stats` with what was left."""

from __future__ import annotations

import asyncio
import threading
from collections.abc import Callable
from typing import Any

from tests.endpoint.drainclient import publish_and_close, twist_number
from tests.endpoint.rawclient import RawClient

from simbridge.endpoint import EndpointOptions
from simbridge.endpoint.backends.base import BackendPublisher
from simbridge.endpoint.backends.local import LocalBus
from simbridge.endpoint.runner import EndpointThread
from simbridge.protocol import (
    CommandReceived,
    MessageReceived,
    Publish,
    RemovePublisher,
    Subscribe,
    TopicListReply,
    TopicListRequest,
)

COUNT = 5000


def test_publish_then_close_delivers_everything_on_the_local_backend() -> None:
    with EndpointThread(EndpointOptions(port=0), LocalBus()) as endpoint:
        subscriber = RawClient(endpoint.port)
        subscriber.send(Subscribe("/drain/local", "geometry_msgs/Twist", COUNT).encode())
        subscriber.stats()  # the subscription is made
        sent = publish_and_close(endpoint.port, "/drain/local", COUNT, COUNT, cdr=False, stats=True)
        got: list[int] = []
        while len(got) < COUNT:
            event = subscriber.expect(lambda e: isinstance(e, MessageReceived), timeout=60)
            got.append(twist_number(event.payload, cdr=False))
        subscriber.close()
    assert got == list(range(COUNT))
    assert sent.stats["session"]["published"] == {"/drain/local": COUNT}
    assert sent.stats["session"]["published_total"] == COUNT


def test_a_publisher_with_nothing_in_flight_leaves_the_graph_at_once() -> None:
    """Nothing to drain (the local bus delivers as it publishes): the topic is gone before
    the next request, as before drains."""
    with EndpointThread(EndpointOptions(port=0), LocalBus()) as endpoint:
        client = RawClient(endpoint.port)
        client.send(Publish("/drain/gone", "geometry_msgs/Twist").encode())
        client.stats()
        client.send(RemovePublisher("/drain/gone").encode() + TopicListRequest().encode())
        reply = client.expect(
            lambda e: isinstance(e, CommandReceived) and isinstance(e.command, TopicListReply)
        )
        drains = client.stats()["server"]["drains"]
        client.close()
    assert "/drain/gone" not in reply.command.topics
    assert drains["drained_publishers"] == 1


class _HeldPublisher(BackendPublisher):
    """A bus publisher whose drain waits for `release` (or gives up at the timeout with
    `left` messages undelivered); records what happened in `log`."""

    def __init__(
        self, inner: BackendPublisher, release: asyncio.Event, left: int, log: list[str]
    ) -> None:
        self._inner, self._release, self._left, self._log = inner, release, left, log

    def publish(self, payload: bytes | bytearray) -> None:
        self._inner.publish(payload)

    def watch_subscribers(self, callback: Callable[[int], None]) -> bool:
        return self._inner.watch_subscribers(callback)

    def in_flight(self) -> bool:
        return True

    async def drain(self, timeout: float) -> int:
        self._log.append("drain")
        try:
            await asyncio.wait_for(self._release.wait(), timeout)
        except TimeoutError:
            return self._left
        return 0

    def close(self) -> None:
        self._log.append("close")
        self._inner.close()


class _HeldBus(LocalBus):
    """The local bus with publishers whose drains the test releases."""

    def __init__(self, left: int) -> None:
        super().__init__()
        self.release: asyncio.Event | None = None
        self.left = left
        self.log: list[str] = []

    async def start(self) -> None:
        await super().start()
        self.release = asyncio.Event()

    def advertise(
        self, topic: str, msg_type: str, *, queue_size: int, latch: bool
    ) -> BackendPublisher:
        assert self.release is not None
        inner = super().advertise(topic, msg_type, queue_size=queue_size, latch=latch)
        return _HeldPublisher(inner, self.release, self.left, self.log)


def _drains(client: RawClient) -> dict[str, Any]:
    drains: dict[str, Any] = client.stats()["server"]["drains"]
    return drains


def _wait_drains(client: RawClient, key: str, value: int) -> dict[str, Any]:
    done = threading.Event()
    for _ in range(600):
        drains = _drains(client)
        if drains[key] == value:
            return drains
        done.wait(0.1)
    raise AssertionError(f"{key} never became {value}: {_drains(client)}")


def test_a_drain_runs_in_the_background_and_the_publisher_closes_after_it() -> None:
    bus = _HeldBus(left=0)
    with EndpointThread(EndpointOptions(port=0, drain_timeout=600), bus) as endpoint:
        subscriber = RawClient(endpoint.port)
        subscriber.send(Subscribe("/drain/held", "geometry_msgs/Twist", 10).encode())
        subscriber.stats()
        publish_and_close(endpoint.port, "/drain/held", 3, 10, cdr=False)
        other = RawClient(endpoint.port)  # served while the drain waits
        assert _wait_drains(other, "draining_publishers", 1)["drained_publishers"] == 0
        assert bus.log == ["drain"]
        assert bus.release is not None
        endpoint.call(bus.release.set)
        drains = _wait_drains(other, "drained_publishers", 1)
        other.close()
        subscriber.close()
    assert drains == {
        "drained_publishers": 1,
        "drain_timeouts": 0,
        "drain_undelivered": 0,
        "draining_publishers": 0,
    }
    assert bus.log == ["drain", "close"]


def test_a_drain_that_hits_the_bound_is_counted_with_what_was_left() -> None:
    bus = _HeldBus(left=7)
    with EndpointThread(EndpointOptions(port=0, drain_timeout=0.05), bus) as endpoint:
        subscriber = RawClient(endpoint.port)
        subscriber.send(Subscribe("/drain/stuck", "geometry_msgs/Twist", 10).encode())
        subscriber.stats()
        publish_and_close(endpoint.port, "/drain/stuck", 3, 10, cdr=False)
        drains = _wait_drains(subscriber, "drain_timeouts", 1)
        subscriber.close()
    assert drains["drain_undelivered"] == 7
    assert drains["drained_publishers"] == 0
    assert bus.log == ["drain", "close"]
