"""What registering returns: a `Publisher` to publish through, a `Subscription` to cancel."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from simbridge.connector.batch import PublishBatch
from simbridge.connector.codec import PayloadCodec
from simbridge.connector.fifo import BoundedFifo
from simbridge.connector.stats import StatsCounters
from simbridge.connector.writer import OutTopic
from simbridge.errors import ConnectorError

__all__ = ["MessageCallback", "MessageTap", "Publisher", "Subscription"]

MessageCallback = Callable[[Any], None]
"""Receives a decoded message, or the payload bytes for a raw subscription."""

MessageTap = Callable[[str, str, bytes, bool], None]
"""Sees every message published or received: (topic, msg_type, payload, outgoing).
Called on the publishing thread or the reader thread, so it must never block
(a recorder queues the payload for its own writer thread)."""


class Publisher:
    """A topic this connector publishes on. `publish` is thread-safe and never blocks."""

    __slots__ = (
        "_batch",
        "_codec",
        "_counters",
        "_fifo",
        "_last",
        "_out",
        "_taps",
        "_write_one",
        "closed",
        "latch",
        "msg_type",
        "queue_size",
        "report_subscribers",
        "subscriber_count",
    )

    def __init__(
        self,
        out: OutTopic,
        *,
        msg_type: str,
        queue_size: int,
        latch: bool,
        report_subscribers: bool,
        fifo: BoundedFifo[OutTopic, bytes],
        codec: PayloadCodec,
        counters: StatsCounters,
        taps: list[MessageTap] | None = None,
        batch: PublishBatch | None = None,
    ) -> None:
        self._out = out
        self._batch = batch
        self._write_one = batch.writer.write_one if batch is not None else None
        """The writer's `write_one`, looked up once (a message published on its own)."""
        self._taps = taps if taps is not None else []
        self.msg_type = msg_type
        self.queue_size = queue_size
        """The ROS-side queue size announced to the endpoint."""
        self.latch = latch
        self.report_subscribers = report_subscribers
        self.subscriber_count: int | None = None
        """Subscribers the endpoint reported (with `report_subscribers`): None while
        unknown (not asked, not connected, or the endpoint lacks the extension), -1 when
        the endpoint's graph cannot tell."""
        self._fifo = fifo
        self._codec = codec
        self._counters = counters
        self._last: bytes | None = None
        self.closed = False
        """Set by `Connector.unregister_publisher`; publishing then raises ConnectorError."""

    @property
    def topic(self) -> str:
        """The topic name."""
        return self._out.topic

    @property
    def out(self) -> OutTopic:
        """The writer's handle for this topic (the key of its outgoing queue)."""
        return self._out

    @property
    def has_subscribers(self) -> bool:
        """False only when the endpoint reported that nobody subscribes right now."""
        return self.subscriber_count != 0

    @property
    def last_payload(self) -> bytes | None:
        """The latest payload of a latched publisher (re-sent after a reconnect)."""
        return self._last

    def forget_last(self) -> None:
        """Drop the remembered latched payload (its serialization went stale)."""
        self._last = None

    def publish(self, msg: object) -> None:
        """Queue one message (an object of `msg_type` or its serialized bytes).

        When the topic already has its bound of unsent messages, the oldest is dropped
        and counted in `Connector.stats().publish_drops`. Inside the connector's `batch()`
        on this thread it leaves with the batch; a small message on its own is written
        from this thread at once (`FrameWriter.write_one`).
        """
        if self.closed:
            raise ConnectorError(f"the publisher on {self.topic!r} was unregistered")
        payload = msg if type(msg) is bytes else self._codec.encode(msg, self.msg_type)
        if self.latch:
            self._last = payload
        out = self._out
        if self._taps:
            for tap in self._taps:
                tap(out.topic, self.msg_type, payload, True)
        batch = self._batch
        if batch is not None:
            pending = batch.pending()
            if pending is not None:
                pending.append((out, payload, out.bound))
                return
            assert self._write_one is not None
            dropped = self._write_one(out, payload)
        else:
            dropped = self._fifo.put(out, payload, out.bound, len(payload))
        if dropped:
            self._counters.publish_dropped(out.topic)


class Subscription:
    """One callback on a topic; `unsubscribe()` cancels just this one."""

    __slots__ = (
        "_codec",
        "_remove",
        "active",
        "callback",
        "msg_type",
        "queue_size",
        "raw",
        "topic",
    )

    def __init__(
        self,
        topic: str,
        msg_type: str,
        callback: MessageCallback,
        *,
        raw: bool,
        queue_size: int,
        codec: PayloadCodec,
        remove: Callable[[Subscription], None],
    ) -> None:
        self.topic = topic
        self.msg_type = msg_type
        self.callback = callback
        self.raw = raw
        self.queue_size = queue_size
        """Received messages waiting for this callback; the oldest is dropped beyond."""
        self._codec = codec
        self._remove = remove
        self.active = True
        """Cleared on unsubscribe: messages still queued for the callback are skipped."""

    def deliver(self, payload: bytes) -> None:
        """Run the callback on one payload (called by the dispatcher, one at a time)."""
        if not self.active:
            return
        if self.raw:
            self.callback(payload)
        else:
            self.callback(self._codec.decode(payload, self.msg_type))

    def unsubscribe(self) -> None:
        """Stop this callback; the topic is unsubscribed when no callback is left."""
        self._remove(self)
