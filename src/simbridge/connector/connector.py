"""The simulation-side ROS-TCP client, with the abilities of Unity's ROSConnection.

Threads: a manager thread connects, reads and parses (and reconnects with back-off);
a writer thread batches queued frames into the socket and sends keepalives; a
dispatch thread runs user callbacks and service handlers. Every registration is kept
and replayed on each new connection, so a restarted endpoint needs no help.
"""

from __future__ import annotations

import asyncio
import functools
import itertools
import logging
import select
import threading
import time
from collections import deque
from concurrent.futures import Future
from concurrent.futures import TimeoutError as FutureTimeoutError
from types import TracebackType
from typing import TYPE_CHECKING, Any

from simbridge.connector.calls import PendingCall, ServiceHandler, ServiceImpl, resolve_future
from simbridge.connector.codec import PayloadCodec, is_raw
from simbridge.connector.dispatcher import Dispatcher, Task
from simbridge.connector.fifo import BoundedFifo
from simbridge.connector.framer import Framer
from simbridge.connector.handles import MessageCallback, Publisher, Subscription
from simbridge.connector.link import Link, open_link
from simbridge.connector.options import ConnectorOptions
from simbridge.connector.reader import FrameReader, Received
from simbridge.connector.stats import ConnectorStats, StatsCounters
from simbridge.connector.writer import FrameWriter, OutTopic
from simbridge.errors import ConnectorError, ServiceError
from simbridge.protocol import (
    KEEPALIVE,
    Command,
    CommandReceived,
    ErrorMessage,
    Event,
    Handshake,
    LogMessage,
    MessageReceived,
    ProtocolConnection,
    ProtocolViolation,
    Publish,
    RemovePublisher,
    RemoveRosService,
    RemoveSubscriber,
    RemoveUnityService,
    RosService,
    ServiceRequestReceived,
    ServiceResponseReceived,
    StatsReply,
    StatsRequest,
    Subscribe,
    SubscriberCount,
    TopicListReply,
    TopicListRequest,
    UnityService,
    WarnMessage,
)

if TYPE_CHECKING:
    from simbridge.messages import MessageRegistry

__all__ = ["Connector"]

_log = logging.getLogger("simbridge.connector")
_POLL_S = 0.1
"""How often the reader wakes while idle to check deadlines and the dead timeout."""


def _check_name(name: str, what: str) -> None:
    if not isinstance(name, str) or not name.strip():
        raise ConnectorError(f"{what} name {name!r} is blank; expected a name such as '/cmd_vel'")
    if any(c.isspace() for c in name):
        raise ConnectorError(f"{what} name {name!r} contains whitespace")
    if name.startswith("__"):
        raise ConnectorError(f"{what} name {name!r} starts with '__', reserved for system commands")


class Connector:
    """A thread-based ROS-TCP client: publish, subscribe, call and implement services."""

    def __init__(
        self,
        host: str = "127.0.0.1",
        port: int = 10000,
        options: ConnectorOptions | None = None,
        registry: MessageRegistry | None = None,
    ) -> None:
        self.host = host
        self.port = port
        self.options = options if options is not None else ConnectorOptions()
        self._codec = PayloadCodec(registry, self.options.protocol)
        self._framer = Framer(self.options.protocol)
        self._counters = StatsCounters()
        self._out: BoundedFifo[OutTopic, bytes] = BoundedFifo()
        self._writer = FrameWriter(self._out, self._counters, self.options.keepalive_interval)
        self._dispatcher = Dispatcher(self._counters)
        self._lock = threading.RLock()
        self._publishers: dict[str, Publisher] = {}
        self._subscriptions: dict[str, tuple[Subscription, ...]] = {}
        self._ros_services: dict[str, str] = {}
        self._unity_services: dict[str, ServiceImpl] = {}
        self._calls: dict[int, PendingCall] = {}
        self._unsent_calls: list[PendingCall] = []
        self._srv_ids = itertools.count(1)
        self._topic_waiters: deque[Future[dict[str, str]]] = deque()
        self._stats_waiters: deque[Future[dict[str, Any]]] = deque()
        self._link: Link | None = None
        self._generation = 0
        self._connected = threading.Event()
        self._closing = threading.Event()
        self._close_deadline = 0.0
        self._manager: threading.Thread | None = None
        self._peer_keepalive: float | None = None
        self._extensions: frozenset[str] = frozenset()
        """simbridge protocol extensions the current endpoint announced."""
        self._handshaken = False
        self.handshake: Handshake | None = None
        """The endpoint's latest handshake (version and metadata)."""

    # ----------------------------------------------------------------- lifecycle

    def connect(self, wait: float | None = 5.0) -> Connector:
        """Start the I/O threads; with `wait`, block until connected (ConnectorError if not).

        Without `wait` it returns at once and connects in the background. Either way it
        keeps reconnecting on its own until `close()`.
        """
        with self._lock:
            if self._closing.is_set():
                raise ConnectorError("this connector was closed; create a new one")
            if self._manager is None:
                self._writer.start()
                self._dispatcher.start()
                self._manager = threading.Thread(
                    target=self._run, name="simbridge-connector", daemon=True
                )
                self._manager.start()
        if wait is not None and not self._connected.wait(wait):
            self.close()
            raise ConnectorError(
                f"no ROS-TCP endpoint answered at {self.host}:{self.port} within {wait} s"
            )
        return self

    def close(self) -> None:
        """Write what is queued (up to `close_flush_timeout`), disconnect, stop all threads.

        Service calls still pending fail with ServiceError.
        """
        if self._closing.is_set():
            return
        grace = self.options.close_flush_timeout
        if self._connected.is_set() and not self._dispatcher.on_thread:
            self.flush(grace)
        self._close_deadline = time.monotonic() + grace
        self._closing.set()
        with self._lock:
            link = self._link
        if link is not None:
            # FIN after the queued data; the reader drains until the endpoint closes too,
            # so the kernel never answers unread input with a reset that loses our data
            link.half_close()
        manager = self._manager
        if manager is not None and manager is not threading.current_thread():
            manager.join(timeout=grace + 1.0)
            if link is not None:
                link.fail()
            manager.join(timeout=5.0)
        self._writer.stop()
        self._dispatcher.stop()
        with self._lock:
            unsent, self._unsent_calls = self._unsent_calls, []
        for call in unsent:
            call.fail(f"connector closed before {call.service} was called")

    def __enter__(self) -> Connector:
        if self._manager is None:
            self.connect()
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    @property
    def connected(self) -> bool:
        """True while a TCP connection to the endpoint is up."""
        return self._connected.is_set()

    def wait_connected(self, timeout: float | None = None) -> bool:
        """Block until connected; False when `timeout` passed first."""
        return self._connected.wait(timeout)

    def flush(self, timeout: float | None = None) -> bool:
        """Wait until every queued frame was handed to the socket; False on timeout."""
        deadline = None if timeout is None else time.monotonic() + timeout
        while not self._writer.idle:
            if not self._connected.is_set() or self._closing.is_set():
                return False
            if deadline is not None and time.monotonic() >= deadline:
                return False
            time.sleep(0.001)
        return True

    def stats(self) -> ConnectorStats:
        """Counters since creation: frames, bytes, drops per topic, reconnects, errors."""
        return self._counters.snapshot()

    # ----------------------------------------------------------------- topics

    def register_publisher(
        self,
        topic: str,
        msg_type: str,
        queue_size: int = 10,
        latch: bool = False,
        report_subscribers: bool = False,
    ) -> Publisher:
        """Advertise `topic`; returns the Publisher.

        With `report_subscribers`, an endpoint that offers the simbridge `subscribers`
        extension keeps `Publisher.subscriber_count` up to date (lazy sensors publish
        only while someone listens). Registering again replaces the registration;
        earlier Publisher objects of the topic keep working and share its queue.
        """
        _check_name(topic, "topic")
        _check_name(msg_type, "message type")
        if queue_size < 0:
            raise ConnectorError(f"queue_size must be >= 0, got {queue_size}")
        with self._lock:
            old = self._publishers.get(topic)
            out = (
                old.out
                if old is not None
                else OutTopic(topic, self._framer.prefix(topic), self.options.publish_queue_size)
            )
            pub = Publisher(
                out,
                msg_type=msg_type,
                queue_size=queue_size,
                latch=latch,
                report_subscribers=report_subscribers,
                fifo=self._out,
                codec=self._codec,
                counters=self._counters,
            )
            self._publishers[topic] = pub
            self._send_command(self._publish_command(pub))
        return pub

    def unregister_publisher(self, topic: str) -> None:
        """Stop publishing on `topic` (messages already queued are still written first)."""
        with self._lock:
            pub = self._publishers.pop(topic, None)
            if pub is not None:
                pub.closed = True
                self._send_command(RemovePublisher(topic))

    def publish(self, topic: str, msg: object) -> None:
        """Queue a message on a registered topic; thread-safe and never blocks."""
        pub = self._publishers.get(topic)
        if pub is None:
            raise ConnectorError(
                f"no publisher registered on {topic!r}; call register_publisher first "
                f"(registered: {sorted(self._publishers) or 'none'})"
            )
        pub.publish(msg)

    def subscribe(
        self,
        topic: str,
        msg_type: str,
        callback: MessageCallback,
        raw: bool = False,
        queue_size: int | None = None,
    ) -> Subscription:
        """Call `callback` (on the dispatch thread) with every message on `topic`.

        `raw=True` passes the payload bytes instead of a decoded message. Several
        callbacks may share a topic if they agree on its type.
        """
        _check_name(topic, "topic")
        _check_name(msg_type, "message type")
        bound = self.options.subscribe_queue_size if queue_size is None else queue_size
        if bound < 1:
            raise ConnectorError(f"queue_size must be >= 1, got {bound}")
        sub = Subscription(
            topic,
            msg_type,
            callback,
            raw=raw,
            queue_size=bound,
            codec=self._codec,
            remove=self._remove_sub,
        )
        with self._lock:
            existing = self._subscriptions.get(topic, ())
            if existing and existing[0].msg_type != msg_type:
                raise ConnectorError(
                    f"{topic!r} is already subscribed as {existing[0].msg_type}, not {msg_type}"
                )
            self._subscriptions[topic] = (*existing, sub)
            if not existing:
                self._send_command(Subscribe(topic, msg_type, bound))
        return sub

    def unsubscribe(self, topic: str) -> None:
        """Remove every callback on `topic` and unsubscribe from it."""
        with self._lock:
            subs = self._subscriptions.pop(topic, None)
            if subs is not None:
                for sub in subs:
                    sub.active = False
                self._send_command(RemoveSubscriber(topic))

    def _remove_sub(self, sub: Subscription) -> None:
        with self._lock:
            existing = self._subscriptions.get(sub.topic, ())
            sub.active = False
            if sub not in existing:
                return
            left = tuple(s for s in existing if s is not sub)
            if left:
                self._subscriptions[sub.topic] = left
            else:
                del self._subscriptions[sub.topic]
                self._send_command(RemoveSubscriber(sub.topic))

    def topic_list(self, timeout: float | None = None) -> dict[str, str]:
        """The endpoint's topics and their types (`__topic_list`)."""
        topics: dict[str, str] = self._ask(TopicListRequest(), self._topic_waiters, timeout)
        return topics

    def endpoint_stats(self, timeout: float | None = None) -> dict[str, Any]:
        """The endpoint's counters for this connection (simbridge `__stats` extension)."""
        stats: dict[str, Any] = self._ask(StatsRequest(), self._stats_waiters, timeout)
        return stats

    def _ask(self, command: Command, waiters: deque[Future[Any]], timeout: float | None) -> Any:
        limit = self.options.request_timeout if timeout is None else timeout
        deadline = time.monotonic() + limit
        if not self._connected.wait(limit):
            raise ConnectorError(f"{command.NAME}: not connected to {self.host}:{self.port}")
        future: Future[Any] = Future()
        with self._lock:
            if self._link is None:
                raise ConnectorError(f"{command.NAME}: connection lost")
            waiters.append(future)
            self._out.put_control(self._framer.command(command))
        try:
            return future.result(max(0.0, deadline - time.monotonic()))
        except FutureTimeoutError:
            future.cancel()
            raise ConnectorError(f"{command.NAME}: no reply within {limit} s") from None

    # ----------------------------------------------------------------- services

    def register_ros_service(self, service: str, srv_type: str) -> None:
        """Declare that this connector calls the ROS service `service` of type `srv_type`."""
        _check_name(service, "service")
        _check_name(srv_type, "service type")
        with self._lock:
            self._ros_services[service] = srv_type
            self._send_command(RosService(service, srv_type))

    def unregister_ros_service(self, service: str) -> None:
        """Undo `register_ros_service`."""
        with self._lock:
            if self._ros_services.pop(service, None) is not None:
                self._send_command(RemoveRosService(service))

    def call_service(
        self, service: str, request: object, timeout: float | None = None, raw: bool = False
    ) -> Future[Any]:
        """Call a registered ROS service; the future gives the response or ServiceError.

        The response is decoded unless the request was bytes or `raw` is set. Calls made
        while disconnected are sent once connected; a connection lost before the answer,
        an `__error` about the call, or `timeout` (default `service_timeout`) fail it.
        """
        srv_type = self._ros_services.get(service)
        if srv_type is None:
            raise ConnectorError(
                f"service {service!r} is not registered; call register_ros_service first "
                f"(registered: {sorted(self._ros_services) or 'none'})"
            )
        if is_raw(request):
            payload = self._codec.encode(request, srv_type)
            response_type = None
        else:
            request_type, response_type_name = self._codec.service_parts(srv_type)
            payload = self._codec.encode(request, request_type)
            response_type = None if raw else response_type_name
        limit = self.options.service_timeout if timeout is None else timeout
        call = PendingCall(service, payload, response_type, time.monotonic() + limit)
        with self._lock:
            if self._closing.is_set():
                call.fail(f"connector closed; {service} not called")
            elif self._link is None:
                self._unsent_calls.append(call)
            else:
                self._send_call(call)
        return call.future

    def call(self, service: str, request: object, timeout: float | None = None) -> Any:
        """Call a ROS service and wait for the response (raises ServiceError)."""
        limit = self.options.service_timeout if timeout is None else timeout
        try:
            return self.call_service(service, request, limit).result(limit + 5.0)
        except FutureTimeoutError:
            raise ServiceError(f"{service} did not answer within {limit} s") from None

    async def call_async(self, service: str, request: object, timeout: float | None = None) -> Any:
        """Call a ROS service from asyncio code."""
        return await asyncio.wrap_future(self.call_service(service, request, timeout))

    def implement_service(
        self, service: str, srv_type: str, handler: ServiceHandler, raw: bool = False
    ) -> None:
        """Serve `service` to ROS: `handler(request) -> response` runs on the dispatch thread.

        With `raw=True` the handler gets the request bytes; it may return bytes or a message.
        """
        _check_name(service, "service")
        _check_name(srv_type, "service type")
        with self._lock:
            self._unity_services[service] = ServiceImpl(service, srv_type, handler, raw)
            self._send_command(UnityService(service, srv_type))

    def unimplement_service(self, service: str) -> None:
        """Stop serving `service`."""
        with self._lock:
            if self._unity_services.pop(service, None) is not None:
                self._send_command(RemoveUnityService(service))

    # ----------------------------------------------------------------- internals

    def _publish_command(self, pub: Publisher) -> Publish:
        """`__publish` for `pub`; asks for subscriber counts only from endpoints that offer
        them (an original endpoint would choke on the extra field)."""
        return Publish(
            pub.topic,
            pub.msg_type,
            pub.queue_size,
            pub.latch,
            report_subscribers=pub.report_subscribers and "subscribers" in self._extensions,
        )

    def _send_command(self, command: Command) -> None:
        """Queue a registration frame (caller holds the lock); replayed on reconnect anyway."""
        if self._link is not None:
            self._out.put_control(self._framer.command(command))

    def _send_call(self, call: PendingCall) -> None:
        call.srv_id = next(self._srv_ids)
        self._calls[call.srv_id] = call
        self._out.put_control(self._framer.service_request(call.srv_id, call.service, call.payload))

    def _run(self) -> None:
        delay = self.options.reconnect_initial
        failures = 0
        while not self._closing.is_set():
            try:
                link = open_link(self.host, self.port, self.options.connect_timeout)
            except OSError as exc:
                failures += 1
                _log.log(
                    logging.WARNING if failures == 1 else logging.DEBUG,
                    "cannot reach the endpoint at %s:%d (%s); retrying in %.1f s",
                    self.host,
                    self.port,
                    exc,
                    delay,
                )
                self._idle(delay)
                delay = min(delay * 2, self.options.reconnect_max)
                continue
            delay = self.options.reconnect_initial
            failures = 0
            with self._lock:
                self._peer_keepalive = None
                self._extensions = frozenset()
                self._handshaken = False
            try:
                self._read(link)
            except OSError as exc:
                if not self._closing.is_set():
                    _log.warning("connection to %s:%d lost: %s", self.host, self.port, exc)
            except Exception:
                _log.exception("connector failure; dropping the connection and reconnecting")
            finally:
                self._teardown(link)
            if not self._closing.is_set():
                _log.info("reconnecting to %s:%d in %.1f s", self.host, self.port, delay)
                self._idle(delay)

    def _idle(self, seconds: float) -> None:
        """Sleep while disconnected, still timing out service calls."""
        end = time.monotonic() + seconds
        while not self._closing.is_set():
            now = time.monotonic()
            self._expire(now)
            if now >= end:
                return
            self._closing.wait(min(_POLL_S, end - now))

    def _setup(self, link: Link) -> None:
        """Replay every registration ahead of anything queued, then hand the link over.

        Runs once the handshake arrived (it tells which simbridge extensions to use).
        """
        framer = self._framer
        with self._lock:
            self._counters.connections += 1
            self._generation += 1
            frames = [KEEPALIVE]
            for pub in self._publishers.values():
                frames.append(framer.command(self._publish_command(pub)))
            for topic, subs in self._subscriptions.items():
                frames.append(
                    framer.command(Subscribe(topic, subs[0].msg_type, subs[0].queue_size))
                )
            for service, srv_type in self._ros_services.items():
                frames.append(framer.command(RosService(service, srv_type)))
            for service, impl in self._unity_services.items():
                frames.append(framer.command(UnityService(service, impl.srv_type)))
            for topic, pub in self._publishers.items():
                last = pub.last_payload
                if last is not None and self._out.pending(pub.out) == 0:
                    frames.append(framer.message(topic, last))
            self._out.put_control_front(frames)
            unsent, self._unsent_calls = self._unsent_calls, []
            for call in unsent:
                self._send_call(call)
            self._link = link
            self._writer.attach(link)
            self._connected.set()
        _log.info("connected to %s:%d", self.host, self.port)

    def _teardown(self, link: Link) -> None:
        """Forget the link; fail whatever was waiting on it."""
        with self._lock:
            self._link = None
            self._connected.clear()
            self._writer.attach(None)
            for pub in self._publishers.values():
                pub.subscriber_count = None
            self._out.discard_control(lambda _frame: False)
            calls = list(self._calls.values())
            self._calls.clear()
            waiters = [*self._topic_waiters, *self._stats_waiters]
            self._topic_waiters.clear()
            self._stats_waiters.clear()
        link.close()
        reason = "connector closed" if self._closing.is_set() else "connection lost"
        for call in calls:
            call.fail(f"{reason} before {call.service} answered (srv_id {call.srv_id})")
        for waiter in waiters:
            resolve_future(waiter, error=ConnectorError(f"{reason} before the endpoint replied"))

    def _expire(self, now: float) -> None:
        expired: list[PendingCall] = []
        with self._lock:
            if self._calls:
                for srv_id, call in list(self._calls.items()):
                    if call.deadline <= now or call.future.done():
                        del self._calls[srv_id]
                        expired.append(call)
            if self._unsent_calls:
                keep: list[PendingCall] = []
                for call in self._unsent_calls:
                    (expired if call.deadline <= now or call.future.done() else keep).append(call)
                self._unsent_calls = keep
        for call in expired:
            call.fail(f"{call.service} did not answer in time (srv_id {call.srv_id})")

    def _read(self, link: Link) -> None:
        """Receive and handle frames until the link breaks, goes silent or the connector closes."""
        max_frame = self.options.max_frame_size
        proto = ProtocolConnection("client", max_payload=max_frame)
        reader = FrameReader(proto, max_frame, self.options.recv_size)
        sock = link.sock
        counters = self._counters
        dead = self.options.dead_timeout
        poller = select.poll()
        poller.register(sock.fileno(), select.POLLIN | select.POLLERR | select.POLLHUP)
        last_rx = last_check = time.monotonic()
        handshake_deadline = last_rx + self.options.connect_timeout
        while not link.broken.is_set():
            ready = poller.poll(_POLL_S * 1000)
            now = time.monotonic()
            if self._closing.is_set() and (now >= self._close_deadline or self._link is not link):
                return
            if now - last_check >= _POLL_S:
                last_check = now
                self._expire(now)
            if not self._handshaken and now >= handshake_deadline:
                _log.warning("no handshake from %s:%d; going on without", self.host, self.port)
                self._handshaken = True
                self._setup(link)
            if not ready:
                keepalive = self._peer_keepalive
                # an endpoint announcing a slow keepalive gets two of its periods
                if keepalive is not None and now - last_rx > max(dead, 2 * keepalive):
                    _log.warning(
                        "endpoint %s:%d silent for %.1f s; dropping the connection",
                        self.host,
                        self.port,
                        now - last_rx,
                    )
                    return
                continue
            count, items = reader.receive(sock)
            if not count:
                if not self._closing.is_set():
                    _log.warning("endpoint %s:%d closed the connection", self.host, self.port)
                return
            last_rx = now
            counters.bytes_received += count
            counters.frames_received += len(items)
            if not self._deliver(items):
                return
            if self._handshaken and self._link is not link:
                self._setup(link)

    def _deliver(self, items: list[Received]) -> bool:
        """Queue messages for their callbacks and act on events, in arrival order."""
        batch: list[tuple[Subscription, bytes | Task, int]] = []
        subscriptions = self._subscriptions
        for item in items:
            if isinstance(item, tuple):
                topic, payload = item
                subs = subscriptions.get(topic)
                if subs is None:
                    _log.debug("message on %r, which is not subscribed; ignored", topic)
                    continue
                for sub in subs:
                    batch.append((sub, payload, sub.queue_size))
                continue
            if batch:
                self._queue_messages(batch)
                batch = []
            if not self._handle(item):
                return False
        if batch:
            self._queue_messages(batch)
        return True

    def _queue_messages(self, batch: list[tuple[Subscription, bytes | Task, int]]) -> None:
        for sub in self._dispatcher.fifo.put_many(batch):
            self._counters.subscribe_dropped(sub.topic)

    def _handle(self, event: Event) -> bool:
        """Act on one event; False when the connection must be dropped."""
        if isinstance(event, MessageReceived):
            self._deliver([(event.topic, event.payload)])
        elif isinstance(event, ServiceResponseReceived):
            with self._lock:
                call = self._calls.pop(event.srv_id, None)
            if call is None:
                _log.debug("response %d for %s came too late", event.srv_id, event.service)
            else:
                call.complete(event.payload, self._codec)
        elif isinstance(event, ServiceRequestReceived):
            impl = self._unity_services.get(event.service)
            if impl is None:
                _log.error(
                    "endpoint called %r, which this connector does not implement", event.service
                )
            else:
                self._dispatcher.submit(
                    functools.partial(
                        self._serve, impl, event.srv_id, event.payload, self._generation
                    )
                )
        elif isinstance(event, CommandReceived):
            self._on_command(event.command)
        elif isinstance(event, ProtocolViolation):
            _log.warning("bad frame from the endpoint: %s", event.text)
            return not event.fatal
        return True

    def _serve(self, impl: ServiceImpl, srv_id: int, payload: bytes, generation: int) -> None:
        """Run a sim-side service handler and queue its response (dispatch thread)."""
        response = impl.serve(payload, self._codec)
        with self._lock:
            if self._generation != generation or self._link is None:
                _log.warning("connection lost before %s could answer", impl.service)
                return
            self._out.put_control(self._framer.service_response(srv_id, impl.service, response))

    def _on_command(self, command: Command) -> None:
        if isinstance(command, Handshake):
            self._on_handshake(command)
        elif isinstance(command, ErrorMessage):
            self._counters.errors_received += 1
            call = None
            if command.srv_id is not None:
                with self._lock:
                    call = self._calls.pop(command.srv_id, None)
            if call is not None:
                call.fail(f"{call.service}: {command.text}")
            else:
                _log.error("endpoint: %s", command.text)
        elif isinstance(command, WarnMessage):
            self._counters.warnings_received += 1
            _log.warning("endpoint: %s", command.text)
        elif isinstance(command, LogMessage):
            self._counters.logs_received += 1
            _log.info("endpoint: %s", command.text)
        elif isinstance(command, TopicListReply):
            self._reply(self._topic_waiters, dict(zip(command.topics, command.types, strict=True)))
        elif isinstance(command, StatsReply):
            self._reply(self._stats_waiters, command.stats)
        elif isinstance(command, SubscriberCount):
            pub = self._publishers.get(command.topic)
            if pub is not None:
                pub.subscriber_count = command.count

    def _reply(self, waiters: deque[Future[Any]], value: Any) -> None:
        with self._lock:
            while waiters:
                waiter = waiters.popleft()
                if not waiter.done():
                    resolve_future(waiter, value)
                    return

    def _on_handshake(self, handshake: Handshake) -> None:
        self.handshake = handshake
        self._handshaken = True
        extensions = handshake.metadata.get("extensions")
        if isinstance(extensions, list):
            self._extensions = frozenset(e for e in extensions if isinstance(e, str))
        if not handshake.version.startswith("v0.7"):
            _log.error(
                "endpoint speaks ROS-TCP %s; this connector expects v0.7.x", handshake.version
            )
        if handshake.protocol != self.options.protocol:
            _log.error(
                "endpoint uses %s serialization but this connector is set to %s",
                handshake.protocol,
                self.options.protocol,
            )
        keepalive = handshake.metadata.get("keepalive")
        if isinstance(keepalive, int | float) and not isinstance(keepalive, bool) and keepalive > 0:
            self._peer_keepalive = float(keepalive)
