"""The ROS 1 backend's native data path: topics over the endpoint's own TCPROS I/O.

rospy still registers each publisher and subscriber with the master (so its slave
API, `rostopic info`, rejoin after a master restart and name resolution keep
working), but no message crosses rospy: subscribers of the endpoint's topics
connect to `TopicServer`, and the endpoint's subscriptions read their publishers
with `SubscribedTopic` connections, all on the event loop.
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Callable
from typing import Any

import rosgraph.network
import rospy

from simbridge.endpoint.backends.base import BackendSubscription, BatchCallback, MessageCallback
from simbridge.endpoint.backends.ros1.raw import RawMessage, RawMessageType
from simbridge.endpoint.backends.ros1.registration import Registration, Ros1Publisher
from simbridge.endpoint.backends.ros1.tcpros_hook import (
    add_bus_info,
    install,
    remove_bus_info,
    route_publication,
    route_subscription,
    unroute,
)
from simbridge.endpoint.backends.ros1.tcpros_pub import PublishedTopic, TopicServer
from simbridge.endpoint.backends.ros1.tcpros_sub import Sink, SubscribedTopic
from simbridge.endpoint.speed.splice import SpliceSink
from simbridge.errors import EndpointError

__all__ = ["NativeData"]

_log = logging.getLogger("simbridge.endpoint.ros1")

_ASK_EVERY = (0.001, 0.02)
"""A drain's first and longest pause between two looks at the connections (doubling)."""


class NativeData:
    """The endpoint's TCPROS server and subscriber connections for one backend."""

    def __init__(self, max_message: int) -> None:
        self._max_message = max_message
        self._server: TopicServer | None = None
        self._host = ""
        self._loop: asyncio.AbstractEventLoop | None = None
        self._subscribed: dict[str, SubscribedTopic] = {}
        self._failed_before = 0
        self._reconnects_before = 0
        self._coalesced_before = 0
        """Counts of the topics no longer subscribed."""

    async def start(self) -> None:
        """Listen where rospy's own TCPROS server would and route rospy's negotiation here."""
        callerid = rospy.get_caller_id()
        self._loop = asyncio.get_running_loop()
        self._server = TopicServer(callerid, self._max_message)
        await self._server.start(rosgraph.network.get_bind_address())
        self._host = rosgraph.network.get_host_name()
        install()
        add_bus_info(self.bus_info)

    def close(self) -> None:
        """Close the server and every connection (registrations are closed before)."""
        remove_bus_info(self.bus_info)
        for name in list(self._subscribed):
            unroute(name, publication=False)
            self._subscribed.pop(name).close()
        if self._server is not None:
            for name in list(self._server.topics):
                unroute(name, publication=True)
            self._server.close()
            self._server = None

    def bus_info(self) -> list[list[Any]]:
        """The endpoint's TCPROS connections as getBusInfo rows (on rospy's XML-RPC thread:
        every collection is copied before it is walked)."""
        rows: list[list[Any]] = []
        server = self._server
        if server is not None:
            for topic in list(server.topics.values()):
                for out in list(topic.connections):
                    rows.append([out.id, out.callerid, "o", "TCPROS", topic.name, True, out.peer])
        for subscribed in list(self._subscribed.values()):
            for uri, conn in list(subscribed.connections.items()):
                rows.append([conn.id, uri, "i", "TCPROS", subscribed.name, True, uri])
        return rows

    def stats(self) -> dict[str, int]:
        """Counters for `__stats`: drops towards slow ROS subscribers, times a subscriber
        fell behind on a topic that may not drop (its publishers' clients pushed back on),
        refused and failed connections, dropped connections to publishers made again, and
        pauses of streaming publisher connections (coalesced reads)."""
        server = self._server
        topics = list(self._subscribed.values())
        return {
            "ros1_dropped_to_ros": server.dropped if server else 0,
            "ros1_pushbacks": server.pushbacks if server else 0,
            "ros1_refused_connections": server.refused if server else 0,
            "ros1_spliced_messages": server.spliced if server else 0,
            "ros1_failed_connections": self._failed_before + sum(t.errors for t in topics),
            "ros1_reconnects": self._reconnects_before + sum(t.reconnects for t in topics),
            "ros1_coalesced_reads": self._coalesced_before + sum(t.coalesced for t in topics),
        }

    def _started(self) -> tuple[TopicServer, asyncio.AbstractEventLoop]:
        if self._server is None or self._loop is None:
            raise EndpointError("the ROS 1 native data path is not started")
        return self._server, self._loop

    def advertise(
        self,
        topic: str,
        cls: type[RawMessage],
        queue_size: int,
        latch: bool,
        live: set[Registration],
    ) -> NativePublisher:
        """Publish `topic` from the endpoint's server; rospy registers it."""
        server, _ = self._started()
        name = rospy.resolve_name(topic)
        info_topic = server.publication(name, _info(cls), latch, queue_size)
        route_publication(name, self._host, server.port)
        try:
            registration = rospy.Publisher(name, cls, queue_size=max(queue_size, 0), latch=latch)
        except BaseException:
            self.release(info_topic)
            raise
        return NativePublisher(self, info_topic, registration, live)

    def release(self, topic: PublishedTopic) -> None:
        """A publisher of `topic` closed: the topic goes once its last one has."""
        server = self._server
        if server is None:
            return
        server.release(topic)
        if topic.name not in server.topics:
            unroute(topic.name, publication=True)

    def subscribe(
        self, topic: str, cls: type[RawMessage], callback: MessageCallback, live: set[Registration]
    ) -> NativeSubscription:
        """Receive `topic` on the loop; rospy registers the subscriber and relays the
        master's publisher lists to the topic's connections."""
        _, loop = self._started()
        name = rospy.resolve_name(topic)
        subscribed = self._subscribed.get(name)
        if subscribed is None:
            subscribed = SubscribedTopic(name, _info(cls), rospy.get_caller_id(), self._max_message)
            self._subscribed[name] = subscribed
            route_subscription(name, loop, subscribed)
        sink = Sink(callback)
        subscribed.sinks.append(sink)
        try:
            registration = rospy.Subscriber(name, cls)
        except BaseException:
            self.leave(subscribed, sink)
            raise
        return NativeSubscription(self, subscribed, sink, registration, live)

    def leave(self, topic: SubscribedTopic, sink: Sink) -> None:
        """A consumer of `topic` closed: the subscription goes once its last one has."""
        if sink in topic.sinks:
            topic.sinks.remove(sink)
        if not topic.sinks and self._subscribed.get(topic.name) is topic:
            del self._subscribed[topic.name]
            unroute(topic.name, publication=False)
            topic.close()
            self._failed_before += topic.errors
            self._reconnects_before += topic.reconnects
            self._coalesced_before += topic.coalesced


def _info(cls: type[RawMessage]) -> RawMessageType:
    return RawMessageType(cls._type, cls._md5sum, cls._full_text)


class NativePublisher(Ros1Publisher):
    """A topic published through the endpoint's TCPROS server."""

    def __init__(
        self,
        data: NativeData,
        topic: PublishedTopic,
        registration: rospy.Publisher,
        live: set[Registration],
    ) -> None:
        self._data = data
        self._topic = topic
        self._registration = registration
        self._watchers: list[Callable[[int], None]] = []
        self._backlog: list[tuple[Callable[[], None], Callable[[], None]]] = []
        self.topic = topic.name
        self.msg_type = topic.info.name
        super().__init__(live)

    def publish(self, payload: bytes | bytearray) -> None:
        if self._closed:  # (the attribute, not the property: one call less per message)
            raise EndpointError(f"publisher of {self.topic!r} is closed")
        self._topic.publish(payload)  # a bytearray is handed over: sent from where it lies

    def subscriber_count(self) -> int:
        return len(self._topic.connections)

    def splice_sink(self) -> SpliceSink | None:
        """The topic's only subscriber's connection, when a large message may go to it
        by splice (`PublishedTopic.splice_sink`)."""
        return None if self._closed else self._topic.splice_sink()

    def watch_subscribers(self, callback: Callable[[int], None]) -> bool:
        """Call `callback(count)` now and whenever a subscriber connects or leaves."""
        self._watchers.append(callback)
        self._topic.watchers.append(callback)
        callback(self.subscriber_count())
        return True

    def watch_backlog(self, behind: Callable[[], None], caught_up: Callable[[], None]) -> bool:
        """Call `behind()` while a subscriber is behind on this topic and it may not drop
        (queue_size 0), `caught_up()` when none is any more."""
        self._backlog.append((behind, caught_up))
        self._topic.backlog_watchers.append((behind, caught_up))
        if self._topic.behind:
            behind()
        return True

    def in_flight(self) -> bool:
        return not self._closed and self._topic.undelivered() > 0

    async def drain(self, timeout: float) -> int:
        """Wait until the kernel has taken every message queued or held for the topic's
        subscribers (their sockets deliver it, also after close), or `timeout` s passed;
        returns 0, or how many were left at most. The topic may be shared with other
        publishers: what they queued is waited for too."""
        loop = asyncio.get_running_loop()
        deadline = loop.time() + timeout
        pause = _ASK_EVERY[0]
        while not self._closed and (left := self._topic.undelivered()):
            if loop.time() >= deadline:
                return left
            await asyncio.sleep(pause)
            pause = min(pause * 2, _ASK_EVERY[1])
        return 0

    def _unregister(self) -> None:
        for callback in self._watchers:
            if callback in self._topic.watchers:
                self._topic.watchers.remove(callback)
        for pair in self._backlog:
            if pair in self._topic.backlog_watchers:
                self._topic.backlog_watchers.remove(pair)
            pair[1]()  # a closed publisher holds nobody back
        self._registration.unregister()
        self._data.release(self._topic)
        _log.info("stopped publishing %s", self.topic)


class NativeSubscription(Registration, BackendSubscription):
    """One consumer of a topic received over the endpoint's TCPROS connections."""

    def __init__(
        self,
        data: NativeData,
        topic: SubscribedTopic,
        sink: Sink,
        registration: rospy.Subscriber,
        live: set[Registration],
    ) -> None:
        self._data = data
        self._subscribed = topic
        self._sink = sink
        self._registration = registration
        self.topic = topic.name
        self.msg_type = topic.info.name
        super().__init__(live)

    def throttle(self, blocked: Callable[[], bool]) -> bool:
        """Stop reading from the publishers while `blocked()` (TCP pushes back on them)."""
        self._sink.blocked = blocked
        return True

    def unblocked(self) -> None:
        self._subscribed.unblocked()

    def batches(self, callback: BatchCallback) -> bool:
        """Messages one read completes go to `callback` at once (while this is the topic's
        only consumer and it is not blocked)."""
        self._sink.batch = callback
        return True

    def _unregister(self) -> None:
        self._registration.unregister()
        self._data.leave(self._subscribed, self._sink)
        _log.info("unsubscribed from %s", self.topic)
