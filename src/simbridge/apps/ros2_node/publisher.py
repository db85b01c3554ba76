"""A Connector for the sim's own ROS 2 node: its topics published straight into rclpy.

`NodeConnector` is a `Connector` whose connection is one end of a socketpair served by an
endpoint in the same process (`Ros2SimNode`): subscriptions, services, actions and
parameters take the endpoint's session as from any client, so they behave as they do
through `simbridge endpoint --backend ros2`. Its publishers skip that hop: a message is
serialized on the publishing thread and handed to the rclpy publisher there
(`DirectPublisher`), as an rclpy node would, with no socket, frame or event loop between.
Lossless topics (queue_size 0) stay on the session, whose push-back slows the sim instead
of dropping.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from simbridge.connector import Connector, ConnectorOptions, Publisher
from simbridge.connector.writer import OutTopic
from simbridge.errors import ConnectorError, SimbridgeError

if TYPE_CHECKING:
    from simbridge.endpoint.backends.base import BackendPublisher
    from simbridge.endpoint.runner import EndpointThread

__all__ = ["DirectPublisher", "NodeConnector"]

_log = logging.getLogger("simbridge.ros2_node")
_CLIENT = "the sim's own node"
"""How drains name this connector's publishers in the endpoint's log."""


class DirectPublisher(Publisher):
    """A topic published by handing each serialized message to its rclpy publisher on the
    calling thread (rcl publishing is thread-safe); nothing is queued, so nothing is
    dropped here (DDS keeps `queue_size` samples per subscriber, as for the endpoint)."""

    __slots__ = ("sink", "using")

    def __init__(self, sink: BackendPublisher, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.sink = sink
        """The backend's publisher (owned by the endpoint's loop: closed there)."""
        self.using = threading.Lock()
        """Held while publishing and while `retire()` marks it closed, so the endpoint
        never destroys the rclpy publisher under a publish in progress."""

    def publish(self, msg: object) -> None:
        """Serialize (unless bytes) and publish now; ConnectorError once unregistered."""
        payload = msg if type(msg) is bytes else self._codec.encode(msg, self.msg_type)
        with self.using:
            if self.closed:
                raise ConnectorError(f"the publisher on {self.topic!r} was unregistered")
            if self.latch:
                self._last = payload
            for tap in self._taps:
                tap(self.topic, self.msg_type, payload, True)
            self.sink.publish(payload)

    def retire(self) -> None:
        """Mark closed once no publish is in progress; later ones raise ConnectorError."""
        with self.using:
            self.closed = True

    def set_subscribers(self, count: int) -> None:
        """The backend's subscriber count (called on the endpoint's loop)."""
        self.subscriber_count = count


class NodeConnector(Connector):
    """A Connector on the sim's own ROS 2 node (see module): connected through a socketpair
    to `endpoint`, an endpoint thread in this process, and publishing directly."""

    def __init__(
        self,
        endpoint: EndpointThread,
        name: str,
        options: ConnectorOptions | None = None,
    ) -> None:
        """`name` labels the node in messages (in place of host:port)."""
        super().__init__(name, 0, options or ConnectorOptions(protocol="ROS2"), dial=endpoint.dial)
        if self.protocol != "ROS2":
            raise ConnectorError(f"the sim's ROS 2 node speaks ROS2, not {self.protocol}")
        self._endpoint = endpoint
        self._direct: dict[str, DirectPublisher] = {}

    def register_publisher(
        self,
        topic: str,
        msg_type: str,
        queue_size: int = 10,
        latch: bool = False,
        report_subscribers: bool = False,
        *,
        raw: bool = False,
    ) -> Publisher:
        """Advertise `topic` on the node (see `Connector.register_publisher`); published
        directly, except a lossless topic (queue_size 0), which goes through the session."""
        if queue_size == 0:
            return super().register_publisher(
                topic, msg_type, queue_size, latch, report_subscribers, raw=raw
            )
        if not raw:
            self._codec.check_type(msg_type, f"publisher {topic}")
        endpoint = self._endpoint
        types, backend = endpoint.server.types, endpoint.backend

        def advertise() -> BackendPublisher:
            return backend.advertise(
                topic, types.message(msg_type), queue_size=queue_size, latch=latch
            )

        try:
            sink = endpoint.call(advertise)
        except SimbridgeError as exc:
            raise ConnectorError(f"cannot advertise {topic!r} [{msg_type}]: {exc}") from None
        pub = DirectPublisher(
            sink,
            out=OutTopic(topic, b"", 1),
            msg_type=msg_type,
            queue_size=queue_size,
            latch=latch,
            report_subscribers=report_subscribers,
            fifo=self._out,
            codec=self._codec,
            counters=self._counters,
            taps=self._taps,
        )
        if report_subscribers:
            watch: Callable[[], bool] = lambda: sink.watch_subscribers(pub.set_subscribers)  # noqa: E731
            if not endpoint.call(watch):
                pub.subscriber_count = -1
        with self._lock:
            old = self._direct.pop(topic, None)
            self._direct[topic] = pub
        if old is not None:
            self._retire([old])
        return pub

    def unregister_publisher(self, topic: str) -> None:
        """Stop publishing on `topic`; what DDS still holds for subscribers is delivered
        first (the endpoint's drain), in the background."""
        with self._lock:
            pub = self._direct.pop(topic, None)
        if pub is None:
            super().unregister_publisher(topic)
        else:
            self._retire([pub])

    def publish(self, topic: str, msg: object) -> None:
        """Publish on a registered topic (see `Connector.publish`)."""
        pub = self._direct.get(topic)
        if pub is None:
            super().publish(topic, msg)
        else:
            pub.publish(msg)

    def close(self) -> None:
        """Retire the direct publishers (drained by the endpoint when it stops), then close
        the connection as any Connector does."""
        with self._lock:
            pubs, self._direct = list(self._direct.values()), {}
        self._retire(pubs)
        super().close()

    def _retire(self, pubs: list[DirectPublisher]) -> None:
        """Mark closed and hand to the endpoint's drains (delivered, then closed)."""
        if not pubs:
            return
        for pub in pubs:
            pub.retire()
        server = self._endpoint.server
        pairs = [(pub.topic, pub.sink) for pub in pubs]
        try:
            self._endpoint.call(lambda: server.drain(_CLIENT, pairs))
        except Exception as exc:  # the endpoint is gone: nothing left to drain into
            _log.warning("could not drain %d publisher(s): %s", len(pairs), exc)
