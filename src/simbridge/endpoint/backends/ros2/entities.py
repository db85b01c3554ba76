"""The ROS 2 backend's node entities: a raw CDR publisher, a subscription whose messages the
event loop takes (`takes`), and a service whose answers come from the sim. Each is made
on the event loop for a backend (`NodeSide`: its node, counters and rclpy thread) and
destroyed once by close().
"""

from __future__ import annotations

import asyncio
import logging
import math
import time
from collections.abc import Callable
from typing import Any, Protocol

from rclpy.duration import Duration
from rclpy.event_handler import PublisherEventCallbacks
from rclpy.qos import HistoryPolicy, QoSProfile
from rclpy.task import Future as RclpyFuture

from simbridge.endpoint.backends.base import (
    BackendPublisher,
    BackendServiceServer,
    BackendSubscription,
    BatchCallback,
    LentCallback,
    MessageCallback,
    ServiceHandler,
)
from simbridge.endpoint.backends.ros2.cdr import (
    from_client,
    interface_name,
    is_empty_interface,
    to_client,
)
from simbridge.endpoint.backends.ros2.rcl import DirectTake, direct_publish, direct_take
from simbridge.endpoint.backends.ros2.takes import LoopTakes
from simbridge.endpoint.backends.subscriber_watch import SubscriberWatch
from simbridge.errors import EndpointError
from simbridge.messages.empty import CLIENT_EMPTY, ros2_empty

__all__ = [
    "NodeEntity",
    "NodeSide",
    "Ros2Publisher",
    "Ros2ServiceServer",
    "Ros2Subscription",
    "SimServiceFailedError",
]

_log = logging.getLogger(__name__)

_TAKE_ROUND = 256
"""Most messages the loop takes from one subscription before it serves anything else."""
_TAKE_ROUND_BYTES = 4 * 1024 * 1024
"""Most bytes it takes from one subscription in a round (a few camera images)."""

_LEND_FROM = 64 * 1024
"""A subscription lending its messages (`lends`) takes them through rcl into its own
buffer (`rcl.DirectTake`) once one was at least this long, and through rclpy (bytes;
a ctypes call costs more than the copy of a small message) once one was shorter."""

_IN_PLACE_MIN = 64 * 1024
"""Bytes payloads this large or larger are published in place (`rcl.direct_publish`):
there publish_raw's copy outweighs the ctypes call's few microseconds."""
_ERROR_LOG_INTERVAL = 5.0
"""Shortest time between two log lines about failed publishes."""

_NOW = Duration(nanoseconds=0)
"""wait_for_all_acked's timeout that only asks (rclpy's wait holds the GIL: a wait of
any length would stop the event loop, so a drain asks every few ms instead)."""
_ASK_EVERY = (0.001, 0.02)
"""A drain's first and longest pause between two questions (it doubles meanwhile)."""


class NodeSide(Protocol):
    """What the node entities need of the backend."""

    @property
    def node(self) -> Any:
        """The rclpy node."""
        ...

    @property
    def counters(self) -> dict[str, int]:
        """The backend's counters (`publish_errors` is counted here)."""
        ...

    def wake_rclpy(self) -> None:
        """Wake the rclpy thread (a future one of its tasks awaits was set elsewhere)."""


class SimServiceFailedError(Exception):
    """A sim-implemented service failed; ROS 2 has no error reply, so the caller gets none."""


class NodeEntity:
    """A node entity that close() destroys, once; `live` holds the backend's open ones."""

    def __init__(self, backend: NodeSide, live: set[NodeEntity]) -> None:
        self._backend = backend
        self._live = live
        self.closed = False
        live.add(self)

    def close(self) -> None:
        if not self.closed:
            self.closed = True
            self._live.discard(self)
            try:
                self._destroy()
            except Exception as exc:  # the node may already be gone
                _log.debug("destroying %s: %s", self, exc)

    def _destroy(self) -> None:
        raise NotImplementedError


class Ros2Publisher(NodeEntity, BackendPublisher):
    """An rclpy publisher of raw CDR bytes; back-pressure failures are counted, not raised."""

    def __init__(
        self,
        backend: NodeSide,
        topic: str,
        cls: Any,
        qos: QoSProfile,
        loop: asyncio.AbstractEventLoop,
        *,
        live: set[NodeEntity],
    ) -> None:
        self._subscribers = SubscriberWatch(loop, self.subscriber_count, lambda: self.closed)
        self._loop = loop
        self._last_error_log = -math.inf  # the first failure is always logged
        self.depth: int = qos.depth if qos.history == HistoryPolicy.KEEP_LAST else 0
        """Samples DDS keeps for a subscriber that has not acknowledged them (0: all)."""
        self.published = 0
        """Messages handed to DDS (a failed publish not counted)."""
        try:
            self._publisher = backend.node.create_publisher(
                cls,
                topic,
                qos,
                event_callbacks=PublisherEventCallbacks(matched=self._on_matched),
            )
        except Exception as exc:
            raise EndpointError(f"cannot advertise {topic!r}: {exc}") from exc
        self.topic: str = self._publisher.topic_name
        self.msg_class = cls
        self._publish_raw = _raw_publish(self._publisher)
        self._publish_lent = direct_publish(self._publisher) or self._publish_raw
        """Large payloads (a bytearray lent by the session, or large bytes from a publisher in
        this process, `simbridge.apps.ros2_node`): published in place, without publish_raw's
        copy (`rcl`)."""
        if is_empty_interface(cls):  # the CDR header alone (Unity) needs the placeholder
            self._publish_raw = self._publish_lent = _spelled_for_ros2(
                self._publish_raw, interface_name(cls)
            )
        super().__init__(backend, live)

    def publish(self, payload: bytes | bytearray) -> None:
        if self.closed:
            raise EndpointError(f"publisher of {self.topic!r} is closed")
        try:
            if type(payload) is bytearray or len(payload) >= _IN_PLACE_MIN:
                self._publish_lent(payload)
            else:
                self._publish_raw(payload)
            self.published += 1
        except Exception as exc:
            counters = self._backend.counters
            counters["publish_errors"] += 1
            now = time.monotonic()
            if now - self._last_error_log >= _ERROR_LOG_INTERVAL:
                self._last_error_log = now
                _log.warning(
                    "publishing on %s failed (%d failures so far): %s",
                    self.topic,
                    counters["publish_errors"],
                    exc,
                )

    def all_acked(self) -> bool:
        """Whether every matched reliable subscription acknowledged every sample (asked
        without waiting)."""
        return bool(self._publisher.wait_for_all_acked(_NOW))

    def in_flight(self) -> bool:
        return not self.closed and not self.all_acked()

    def undelivered(self) -> int:
        """How many samples DDS may still hold for a subscriber, at most (none may be)."""
        return min(self.published, self.depth) if self.depth else self.published

    async def drain(self, timeout: float) -> int:
        """Ask DDS every few ms whether every subscriber acknowledged every sample, until
        it has or `timeout` s passed; returns 0, or `undelivered()`."""
        return await self._acked_within(timeout)

    async def _acked_within(self, timeout: float) -> int:
        deadline = self._loop.time() + timeout
        pause, longest = _ASK_EVERY
        while not self.closed and not self.all_acked():
            if self._loop.time() >= deadline:
                return self.undelivered()
            await asyncio.sleep(pause)
            pause = min(pause * 2, longest)
        return 0

    def subscriber_count(self) -> int:
        """Subscriptions matched with this publisher now."""
        return int(self._publisher.get_subscription_count())

    def watch_subscribers(self, callback: Callable[[int], None]) -> bool:
        return self._subscribers.add(callback)

    def _on_matched(self, _info: Any) -> None:
        """Runs on the rclpy thread."""
        self._subscribers.changed()

    def _destroy(self) -> None:
        self._backend.node.destroy_publisher(self._publisher)
        _log.info("stopped publishing %s", self.topic)


def _spelled_for_ros2(
    publish: Callable[[bytes | bytearray], None], name: str
) -> Callable[[bytes | bytearray], None]:
    """`publish` of an empty type's CDR in ROS 2's spelling, whichever a client sent."""

    def publish_empty(payload: bytes | bytearray) -> None:
        publish(ros2_empty(payload, name))

    return publish_empty


def _raw_publish(publisher: Any) -> Callable[[bytes | bytearray], None]:
    """The C++ publisher's `publish_raw`: what `Publisher.publish(bytes)` ends in, without
    its handle guard and type checks (about 2 us of a Twist's publish); it takes a bytearray
    too (a large payload as received, not copied to bytes first). The guard keeps another
    thread from destroying the publisher meanwhile; here publishing and destroying both
    happen on the event loop. Falls back to `publish` (bytes only) if rclpy hides it."""
    inner = getattr(publisher, "_Publisher__publisher", None)
    raw = getattr(inner, "publish_raw", None)
    if callable(raw):
        return raw  # type: ignore[no-any-return]
    return lambda payload: publisher.publish(bytes(payload))


class Ros2Subscription(NodeEntity, BackendSubscription):
    """A raw rclpy subscription whose CDR bytes the event loop takes (`takes`)."""

    def __init__(
        self,
        backend: NodeSide,
        topic: str,
        cls: Any,
        qos: QoSProfile,
        *,
        takes: LoopTakes,
        callback: MessageCallback,
        live: set[NodeEntity],
    ) -> None:
        self._callback = callback
        self._batch: BatchCallback | None = None
        self._cls = cls
        self._empty = is_empty_interface(cls)
        """Clients get an empty type's CDR as the header alone, not rclpy's padding."""
        self._takes = takes
        self._lent: LentCallback | None = None
        self._direct: DirectTake | None = None
        self._lending = False
        """Whether the next take goes through `_direct` (the last message was large)."""
        try:
            self._subscription = backend.node.create_subscription(
                cls, topic, _never_called, qos, callback_group=takes.callback_group, raw=True
            )
        except Exception as exc:
            raise EndpointError(f"cannot subscribe to {topic!r}: {exc}") from exc
        self.topic: str = self._subscription.topic_name
        self.handle: Any = self._subscription.handle
        super().__init__(backend, live)
        takes.add(self)

    def batches(self, callback: BatchCallback) -> bool:
        """What one round takes goes to `callback` in one call (the session frames a run
        of small messages with one header and one write) instead of one callback each."""
        self._batch = callback
        return True

    def lends(self, callback: LentCallback) -> bool:
        """Large messages go to `callback` as views of this subscription's own take buffer
        (no bytes object made of them); False when rcl cannot be reached through ctypes."""
        if self._direct is None:
            self._direct = direct_take(self._subscription)
        self._lent = callback if self._direct is not None else None
        return self._lent is not None

    def take_round(self) -> bool:
        """On the loop: take what is waiting, up to _TAKE_ROUND messages or
        _TAKE_ROUND_BYTES, and hand them over together (`_hand_over`; a large message taken
        into the lent buffer goes to the lent callback at once, after what came before
        it); True when a bound ended the round (more may be waiting), False when it found
        none left."""
        if self.closed:
            return False
        handle, cls = self.handle, self._cls
        payloads: list[bytes] = []
        append = payloads.append
        size = 0
        more = True
        try:
            with handle:
                take = handle.take_message
                for _ in range(_TAKE_ROUND):
                    if self._lending:
                        if payloads:  # what was taken before it goes first
                            self._hand_over(payloads)
                            payloads = []
                            append = payloads.append
                        length = self._take_lent()
                        if length < 0:
                            more = False
                            break
                    else:
                        taken = take(cls, True)
                        if taken is None:
                            more = False
                            break
                        payload = taken[0]
                        append(payload)
                        length = len(payload)
                        self._lending = length >= _LEND_FROM and self._lent is not None
                    size += length
                    if size >= _TAKE_ROUND_BYTES:
                        break
                    if self.closed:
                        return False
            self._hand_over(payloads)
        except Exception as exc:  # destroyed meanwhile, or the callback failed
            if not self.closed:
                _log.error("taking from %s failed", self.topic, exc_info=exc)
            return False
        return more and not self.closed

    def _hand_over(self, payloads: list[bytes]) -> None:
        """Messages taken together, in order: to the batch callback when there are several
        (it takes what its client can have now), the rest one by one to the message
        callback (which queues or drops by the client's queue_size: DDS cannot take
        them back)."""
        if self._empty:
            payloads = [CLIENT_EMPTY] * len(payloads)
        batch = self._batch
        rest: list[bytes] = payloads
        if batch is not None and len(payloads) > 1:
            taken = batch(payloads)
            rest = payloads[taken:] if taken < len(payloads) else []
        callback = self._callback
        for payload in rest:
            if self.closed:
                return
            callback(payload)

    def _take_lent(self) -> int:
        """One message through the take buffer to the lent callback: its length, or -1
        when none was waiting. The view is released after the call, so one kept by
        mistake raises instead of showing the next message."""
        direct, lent = self._direct, self._lent
        assert direct is not None
        assert lent is not None
        view = direct.take()
        if view is None:
            return -1
        length = len(view)
        try:
            lent(view)
        finally:
            view.release()
        self._lending = length >= _LEND_FROM
        return length

    def _destroy(self) -> None:
        self._takes.remove(self)
        try:
            self._backend.node.destroy_subscription(self._subscription)
        finally:
            if self._direct is not None:
                self._direct.close()
        _log.info("unsubscribed from %s", self.topic)


def _never_called(_payload: bytes) -> None:
    """The rclpy callback of a subscription the executor never runs (its group says so)."""


class Ros2ServiceServer(NodeEntity, BackendServiceServer):
    """An rclpy service whose answer comes from an async handler on the event loop.

    The rclpy callback is a coroutine: it waits on an rclpy Future that the event
    loop completes, so the executor keeps serving other traffic meanwhile.
    """

    def __init__(
        self,
        backend: NodeSide,
        service: str,
        cls: Any,
        *,
        loop: asyncio.AbstractEventLoop,
        handler: ServiceHandler,
        timeout: float,
        live: set[NodeEntity],
    ) -> None:
        self._service = service
        self._cls = cls
        self._loop = loop
        self._handler = handler
        self._timeout = timeout
        try:
            self._server = backend.node.create_service(cls, service, self._on_request)
        except Exception as exc:
            raise EndpointError(f"cannot advertise service {service!r}: {exc}") from exc
        super().__init__(backend, live)

    async def _run(self, request: bytes) -> bytes:
        return await asyncio.wait_for(self._handler(request), self._timeout)

    async def _on_request(self, request: Any, _response: Any) -> Any:
        """Runs as an rclpy task on the rclpy thread."""
        if self.closed or self._loop.is_closed():
            raise SimServiceFailedError(
                f"service {self._service} is being removed; request dropped"
            )
        answer = RclpyFuture()
        backend = self._backend
        payload = to_client(request)
        call = asyncio.run_coroutine_threadsafe(self._run(payload), self._loop)

        def finished(done: Any) -> None:
            try:
                answer.set_result(done.result())
            except BaseException as exc:  # the handler's failure, for the rclpy task
                answer.set_exception(exc)
            backend.wake_rclpy()

        call.add_done_callback(finished)
        try:
            response = await answer
        except TimeoutError as exc:
            raise SimServiceFailedError(
                f"the sim did not answer {self._service} within {self._timeout:g} s; "
                "the ROS 2 caller gets no response"
            ) from exc
        except Exception as exc:
            raise SimServiceFailedError(
                f"the sim failed {self._service}: {exc}; the ROS 2 caller gets no response"
            ) from exc
        try:
            return from_client(response, self._cls.Response)
        except Exception as exc:
            raise SimServiceFailedError(
                f"the sim's answer to {self._service} is not a CDR "
                f"{self._cls.__name__} response: {exc}"
            ) from exc

    def _destroy(self) -> None:
        self._backend.node.destroy_service(self._server)
        _log.info("stopped serving %s", self._service)
