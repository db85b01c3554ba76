"""The connector's machinery: shared state and the I/O threads' work.

Two dispatcher workers take turns connecting, reading and parsing (and reconnecting
with back-off) and running user callbacks and service handlers: the one that read the
data runs its callbacks, and the other takes reading over while they run long
(`dispatcher.py`); a writer thread batches queued frames into the socket and sends
keepalives. Every registration is kept here and replayed
on each new connection, so a restarted endpoint needs no help. `Connector` adds the
public API on top.
"""

from __future__ import annotations

import functools
import itertools
import logging
import socket
import struct
import threading
import time
from collections import deque
from collections.abc import Callable
from concurrent.futures import Future
from typing import TYPE_CHECKING, Any, Literal

from simbridge.connector.batch import PublishBatch
from simbridge.connector.calls import PendingCall, ServiceImpl, resolve_future
from simbridge.connector.codec import PayloadCodec
from simbridge.connector.dispatcher import Dispatcher
from simbridge.connector.fifo import BoundedFifo
from simbridge.connector.framer import Framer
from simbridge.connector.goals import GoalRouter
from simbridge.connector.handles import MessageTap, Publisher, Subscription
from simbridge.connector.link import Link, open_link
from simbridge.connector.options import ConnectorOptions
from simbridge.connector.reader import FrameReader, Received
from simbridge.connector.served import ServedRouter
from simbridge.connector.stats import StatsCounters
from simbridge.connector.writer import FrameWriter, OutTopic
from simbridge.errors import ConnectorError
from simbridge.protocol import (
    ACTION_SERVERS_EXTENSION,
    DEFAULT_SUBSCRIBE_QUEUE,
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
    RosService,
    ServiceFailure,
    ServiceRequestReceived,
    ServiceResponseReceived,
    SetParam,
    StatsReply,
    Subscribe,
    SubscriberCount,
    TopicListReply,
    UnityService,
    WarnMessage,
)

if TYPE_CHECKING:
    from simbridge.messages import MessageRegistry

__all__ = ["ConnectorEngine"]

_log = logging.getLogger("simbridge.connector")
_POLL_S = 0.1
"""How often the reader wakes while idle to check deadlines and the dead timeout."""
_RECV_TIMEOUT = struct.pack("@ll", 0, int(_POLL_S * 1e6))
"""`_POLL_S` as the `struct timeval` of SO_RCVTIMEO."""


class _Reading:
    """The I/O role's state for one connection, kept between steps (either worker may
    run the next one)."""

    __slots__ = ("handshake_deadline", "last_check", "last_rx", "link", "reader")

    def __init__(
        self, link: Link, reader: FrameReader, now: float, handshake_deadline: float
    ) -> None:
        self.link = link
        self.reader = reader
        self.last_rx = now
        self.last_check = now
        self.handshake_deadline = handshake_deadline


class ConnectorEngine:
    """State shared by the public API and the I/O threads, and what those threads do."""

    def __init__(
        self,
        host: str = "127.0.0.1",
        port: int = 10000,
        options: ConnectorOptions | None = None,
        registry: MessageRegistry | None = None,
        *,
        dial: Callable[[], socket.socket] | None = None,
    ) -> None:
        """`dial`: how to reach the endpoint instead of TCP to host:port, a connected
        stream socket per call (an endpoint in this process, on one end of a socketpair);
        host and port then only name it in messages."""
        self.host = host
        self.port = port
        self._dial = dial
        self.options = options if options is not None else ConnectorOptions()
        forced = self.options.protocol
        self.protocol: Literal["ROS1", "ROS2"] = "ROS1" if forced == "auto" else forced
        """The serialization in use: forced by the options, or the endpoint's (auto)."""
        self._codec = PayloadCodec(registry, self.protocol)
        self._framer = Framer(self.protocol)
        self._counters = StatsCounters()
        self._out: BoundedFifo[OutTopic, bytes] = BoundedFifo()
        self._writer = FrameWriter(self._out, self._counters, self.options.keepalive_interval)
        self._batch = PublishBatch(self._writer, self._counters)
        self._dispatcher = Dispatcher(self._counters, self._io_step)
        self._lock = threading.RLock()
        self._publishers: dict[str, Publisher] = {}
        self._subscriptions: dict[str, tuple[Subscription, ...]] = {}
        self._taps: list[MessageTap] = []
        """Observers of every message in and out (`Connector.add_tap`); the same list
        object is shared with every publisher."""
        self._ros_services: dict[str, str] = {}
        self._unity_services: dict[str, ServiceImpl] = {}
        self._params: dict[str, Any] = {}
        """ROS parameters set through `Connector.set_param`, set again on every connection."""
        self._calls: dict[int, PendingCall] = {}
        self._unsent_calls: list[PendingCall] = []
        self._unreachable: str | None = None
        """Why the last attempt to reach the endpoint failed; None while it is reachable."""
        self._srv_ids = itertools.count(1)
        self._topic_waiters: deque[Future[dict[str, str]]] = deque()
        self._stats_waiters: deque[Future[dict[str, Any]]] = deque()
        self._link: Link | None = None
        self._generation = 0
        self._connected = threading.Event()
        self._closing = threading.Event()
        self._close_deadline = 0.0
        self._started = False
        self._conn: _Reading | None = None
        """The connection being read; None while connecting or backing off."""
        self._retry_at = 0.0
        """When the next connection attempt may start."""
        self._delay = self.options.reconnect_initial
        """Back-off before the attempt after the next failure or loss."""
        self._failures = 0
        self._peer_keepalive: float | None = None
        self._extensions: frozenset[str] = frozenset()
        """simbridge protocol extensions the current endpoint announced."""
        self._goals = GoalRouter()
        """ROS 2 action goals in flight (the `actions` extension)."""
        self._served = ServedRouter(self._send_served)
        """ROS 2 actions served from here (the `action_servers` extension)."""
        self._handshaken = False
        self.handshake: Handshake | None = None
        """The endpoint's latest handshake (version and metadata)."""

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
        """Queue a registration frame (caller holds the lock); replayed on reconnect anyway.
        Messages this thread's open batch holds go first, as they were published first."""
        self._batch.send_pending()
        if self._link is not None:
            self._out.put_control(self._framer.command(command))

    def _subscribe_command(self, topic: str, msg_type: str, queue_size: int) -> Subscribe:
        """`__subscribe` with the queue bound only for an endpoint that announced
        `subscribe_queue`: the original endpoint's connection thread dies on extra fields."""
        if "subscribe_queue" not in self._extensions:
            queue_size = DEFAULT_SUBSCRIBE_QUEUE
        return Subscribe(topic, msg_type, queue_size)

    def _send_extension(self, command: Command, extension: str) -> None:
        """Queue an extension's command now; ConnectorError when not connected or when the
        endpoint did not announce `extension` (the original endpoint's connection thread
        dies on system commands it does not know)."""
        with self._lock:
            if self._link is None:
                raise ConnectorError(f"{command.NAME}: not connected to {self.host}:{self.port}")
            if extension not in self._extensions:
                raise ConnectorError(
                    f"the endpoint at {self.host}:{self.port} does not offer {command.NAME} "
                    f"(extension {extension!r}; announced extensions: "
                    f"{sorted(self._extensions) or 'none'})"
                )
            self._out.put_control(self._framer.command(command))

    def _send_call(self, call: PendingCall) -> None:
        call.srv_id = next(self._srv_ids)
        self._calls[call.srv_id] = call
        self._out.put_control(self._framer.service_request(call.srv_id, call.service, call.payload))

    def _io_step(self) -> bool:
        """One bounded piece of the connection's life: a connection attempt, one read, or
        a slice of the back-off before the next attempt (run by whichever dispatcher
        worker holds the I/O role). False once the connector closed."""
        conn = self._conn
        if conn is not None:
            try:
                if self._read_once(conn):
                    return True
            except OSError as exc:
                if not self._closing.is_set():
                    _log.warning("connection to %s:%d lost: %s", self.host, self.port, exc)
            except Exception:
                _log.exception("connector failure; dropping the connection and reconnecting")
            self._conn = None
            self._teardown(conn.link)
            if self._closing.is_set():
                return False
            _log.info("reconnecting to %s:%d in %.1f s", self.host, self.port, self._delay)
            self._retry_at = time.monotonic() + self._delay
            return True
        if self._closing.is_set():
            return False
        now = time.monotonic()
        self._expire(now)
        if now < self._retry_at:
            self._closing.wait(min(_POLL_S, self._retry_at - now))
            return True
        try:
            link = (
                Link(self._dial())
                if self._dial is not None
                else open_link(self.host, self.port, self.options.connect_timeout)
            )
        except OSError as exc:
            self._failures += 1
            self._unreachable = str(exc) or type(exc).__name__
            _log.log(
                logging.WARNING if self._failures == 1 else logging.DEBUG,
                "cannot reach the endpoint at %s:%d (%s); retrying in %.1f s",
                self.host,
                self.port,
                exc,
                self._delay,
            )
            self._retry_at = time.monotonic() + self._delay
            self._delay = min(self._delay * 2, self.options.reconnect_max)
            return True
        self._delay = self.options.reconnect_initial
        self._failures = 0
        self._unreachable = None
        with self._lock:
            self._peer_keepalive = None
            self._extensions = frozenset()
            self._handshaken = False
        self._conn = self._open(link)
        return True

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
                    framer.command(
                        self._subscribe_command(topic, subs[0].msg_type, subs[0].queue_size)
                    )
                )
            for service, srv_type in self._ros_services.items():
                frames.append(framer.command(RosService(service, srv_type)))
            for service, impl in self._unity_services.items():
                frames.append(framer.command(UnityService(service, impl.srv_type)))
            if ACTION_SERVERS_EXTENSION in self._extensions:
                frames.extend(framer.command(c) for c in self._served.registrations())
            if self._params and "set_param" in self._extensions:
                frames.extend(framer.command(SetParam(k, v)) for k, v in self._params.items())
            elif self._params:
                _log.warning(
                    "the endpoint at %s:%d does not offer the set_param extension (the "
                    "original ROS-TCP endpoint has none); parameters not set: %s",
                    self.host,
                    self.port,
                    ", ".join(sorted(self._params)),
                )
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
        lost = functools.partial(
            self._goals.lost,
            f"{reason} before the goal ended (the endpoint cancels the goals of a client "
            "that leaves)",
        )
        if self._closing.is_set():
            lost()
            self._served.lost()
        else:
            self._dispatcher.submit(lost)  # after the frames already queued for the goals
            self._dispatcher.submit(self._served.lost)

    def _expire(self, now: float) -> None:
        expired: list[PendingCall] = []
        unsent: list[PendingCall] = []
        with self._lock:
            if self._calls:
                for srv_id, call in list(self._calls.items()):
                    if call.deadline <= now or call.future.done():
                        del self._calls[srv_id]
                        expired.append(call)
            if self._unsent_calls:
                keep: list[PendingCall] = []
                for call in self._unsent_calls:
                    (unsent if call.deadline <= now or call.future.done() else keep).append(call)
                self._unsent_calls = keep
        for call in expired:
            call.fail(f"{call.service} did not answer in time (srv_id {call.srv_id})")
        reason = self._unreachable or "not connected"
        for call in unsent:
            call.fail(
                f"the endpoint at {self.host}:{self.port} was unreachable ({reason}); "
                f"the call of {call.service} was never sent"
            )

    def _open(self, link: Link) -> _Reading:
        """Reading state for a new connection."""
        max_frame = self.options.max_frame_size
        proto = ProtocolConnection("client", max_payload=max_frame)
        # A blocking read that gives up after _POLL_S (SO_RCVTIMEO) wakes the reader for
        # its deadlines as a poll() would, with one system call per read instead of two.
        link.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVTIMEO, _RECV_TIMEOUT)
        now = time.monotonic()
        return _Reading(
            link,
            FrameReader(proto, max_frame, self.options.recv_size),
            now,
            now + self.options.connect_timeout,
        )

    def _read_once(self, conn: _Reading) -> bool:
        """One read: handle what it completed; False when the link broke, went silent or
        the connector closed (the caller tears it down)."""
        link = conn.link
        if link.broken:
            return False
        try:
            count, items = conn.reader.receive(link.sock)
            ready = True
        except (BlockingIOError, TimeoutError):  # SO_RCVTIMEO passed with nothing read
            ready = False
        now = time.monotonic()
        # (the deadline is set before closing is: no Event call per read while open)
        if (
            self._close_deadline
            and self._closing.is_set()
            and (now >= self._close_deadline or self._link is not link)
        ):
            return False
        if now - conn.last_check >= _POLL_S:
            conn.last_check = now
            self._expire(now)
        if not self._handshaken and now >= conn.handshake_deadline:
            _log.warning("no handshake from %s:%d; going on without", self.host, self.port)
            self._handshaken = True
            self._setup(link)
        if not ready:
            keepalive = self._peer_keepalive
            # an endpoint announcing a slow keepalive gets two of its periods
            if keepalive is not None and now - conn.last_rx > max(
                self.options.dead_timeout, 2 * keepalive
            ):
                _log.warning(
                    "endpoint %s:%d silent for %.1f s; dropping the connection",
                    self.host,
                    self.port,
                    now - conn.last_rx,
                )
                return False
            return True
        if not count:
            if not self._closing.is_set():
                _log.warning("endpoint %s:%d closed the connection", self.host, self.port)
            return False
        conn.last_rx = now
        counters = self._counters
        counters.bytes_received += count
        counters.frames_received += len(items)
        if not self._deliver(items):
            return False
        if self._handshaken and self._link is not link:
            self._setup(link)
        return True

    def _deliver(self, items: list[Received]) -> bool:
        """Queue messages for their callbacks and act on events, in arrival order."""
        batch: list[tuple[Subscription, bytes]] = []
        subscriptions = self._subscriptions
        taps = self._taps
        last: str | None = None
        subs: tuple[Subscription, ...] | None = None
        for item in items:
            if isinstance(item, tuple):
                topic, payload = item
                if topic is not last:  # a burst on one topic shares the reader's str
                    last, subs = topic, subscriptions.get(topic)
                if subs is None:
                    _log.debug("message on %r, which is not subscribed; ignored", topic)
                    continue
                if taps:
                    for tap in taps:
                        tap(topic, subs[0].msg_type, payload, False)
                if len(subs) == 1:
                    batch.append((subs[0], payload))
                else:
                    batch.extend((sub, payload) for sub in subs)
                continue
            if batch:
                self._dispatcher.put_messages(batch)
                batch = []
            last = None  # handling an event may change the subscriptions
            if not self._handle(item):
                return False
        if batch:
            self._dispatcher.put_messages(batch)
        return True

    def _handle(self, event: Event) -> bool:
        """Act on one event; False when the connection must be dropped."""
        if isinstance(event, MessageReceived):
            self._deliver([(event.topic, bytes(event.payload))])  # the API promises bytes
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
        """Run a sim-side service handler and queue its response (run as a callback).

        A failing handler is logged; an endpoint offering the `service_error` extension
        is told, so the ROS caller gets the error at once instead of timing out.
        """
        failure: str | None = None
        try:
            response = impl.serve(payload, self._codec)
        except Exception as exc:
            _log.exception("service handler for %s failed", impl.service)
            self._counters.callback_failed()
            failure = f"{type(exc).__name__}: {exc}"
        with self._lock:
            if self._generation != generation or self._link is None:
                _log.warning("connection lost before %s could answer", impl.service)
                return
            if failure is None:
                frame = self._framer.service_response(srv_id, impl.service, response)
            elif "service_error" in self._extensions:
                frame = self._framer.command(ServiceFailure(srv_id, failure))
            else:
                return
            self._out.put_control(frame)

    def _send_served(self, command: Command) -> None:
        """Send an `action_servers` command; dropped (logged) while not connected: the
        endpoint aborted the goals of the connection that is gone."""
        try:
            self._send_extension(command, ACTION_SERVERS_EXTENSION)
        except ConnectorError as exc:
            _log.debug("%s not sent: %s", command.NAME, exc)

    def _on_command(self, command: Command) -> None:
        if self._served.takes(command):
            self._dispatcher.submit(functools.partial(self._served.handle, command))
        elif self._goals.takes(command):
            if isinstance(command, ErrorMessage):
                self._counters.errors_received += 1
                _log.warning("endpoint: %s", command.text)
            self._dispatcher.submit(functools.partial(self._goals.handle, command))
        elif isinstance(command, Handshake):
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

    def _switch_protocol(self, protocol: Literal["ROS1", "ROS2"]) -> None:
        """Follow the endpoint's serialization (auto mode). Messages serialized before
        the handshake told it are dropped and counted, never sent in the wrong format."""
        with self._lock:
            _log.info("endpoint speaks %s; switching serialization to it", protocol)
            self.protocol = protocol
            self._codec.set_protocol(protocol)
            self._framer = Framer(protocol)
            registry = self._codec.registry
            if registry.protocol != protocol:
                _log.error("the connector's registry has %s layouts", registry.protocol)
            stale = {pub.out for pub in self._publishers.values()}
            for pub in self._publishers.values():
                pub.out.prefix = self._framer.prefix(pub.topic)
                pub.forget_last()
            for topic in self._out.discard_keys(stale):
                self._counters.publish_dropped(topic.topic)

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
        if handshake.protocol != self.protocol:
            if self.options.protocol == "auto" and handshake.protocol == "ROS2":
                self._switch_protocol("ROS2")
            elif self.options.protocol == "auto" and handshake.protocol == "ROS1":
                self._switch_protocol("ROS1")
            else:
                _log.error(
                    "endpoint uses %s serialization but this connector is set to %s",
                    handshake.protocol,
                    self.protocol,
                )
        keepalive = handshake.metadata.get("keepalive")
        if isinstance(keepalive, int | float) and not isinstance(keepalive, bool) and keepalive > 0:
            self._peer_keepalive = float(keepalive)
