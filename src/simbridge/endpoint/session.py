"""One client connection of the endpoint: its registrations, queues and service calls."""

from __future__ import annotations

import asyncio
import contextlib
import functools
import itertools
import logging
import os
import struct
import time
from collections import deque
from collections.abc import Awaitable, Callable, Coroutine, Mapping, Sequence
from typing import TYPE_CHECKING, Any

from simbridge.endpoint.backends.base import (
    BackendPublisher,
    BackendServiceServer,
    BackendSubscription,
)
from simbridge.endpoint.deferred import deferred_writes
from simbridge.endpoint.pushback import ReadGate, ReadPushback, pushback_limit
from simbridge.endpoint.session_actions import SessionActions
from simbridge.endpoint.speed.splice import SpliceRelay, can_splice
from simbridge.endpoint.speed.writev import WRITE_ALONE, write_chunks
from simbridge.endpoint.stats import SessionStats
from simbridge.errors import EndpointError, ServiceError, SimbridgeError
from simbridge.protocol import (
    EXTENSIONS,
    KEEPALIVE,
    ActionCancel,
    ActionGoal,
    ActionServerQuery,
    CommandReceived,
    ErrorMessage,
    Event,
    Handshake,
    KeepaliveReceived,
    MessageReceived,
    ProtocolConnection,
    ProtocolViolation,
    Publish,
    RemovePublisher,
    RemoveRosService,
    RemoveSubscriber,
    RemoveUnityService,
    RosService,
    ServiceFailure,
    ServiceRequestReceived,
    ServiceResponseReceived,
    SetParam,
    StatsReply,
    StatsRequest,
    Subscribe,
    SubscriberCount,
    TopicListReply,
    TopicListRequest,
    UnityService,
    WarnMessage,
    shorten,
)
from simbridge.protocol.commands import MAX_COMMAND_SIZE, Command
from simbridge.protocol.framing import FrameDecoder
from simbridge.tcp import tune_stream

if TYPE_CHECKING:
    from simbridge.endpoint.server import EndpointServer

__all__ = ["ClientSession"]

log = logging.getLogger("simbridge.endpoint")
_pack_u32 = struct.Struct("<I").pack

_ENTRY_OVERHEAD = 64
"""Bytes a queued message costs beyond its payload (object header, queue slot), charged to
the memory budget so a million empty messages are not free."""


_MAX_REMEMBERED = 1024
"""Unregistered topics remembered (to rate-limit their errors) before forgetting all."""

_MAX_ERROR_TEXT = 1000
"""Longest `__error` text (and log line) sent; every echoed name is already shortened."""

_BLOCK_LIMIT = 2.0
"""Seconds a subscription may push back on its ROS publishers while its client is not
reading, before its messages are dropped (past its queue_size) instead."""

FIRST_SRV_ID = 1001
"""Ids of endpoint-initiated service requests start here, as in the original endpoint."""


class _Outbox:
    """A subscription's bounded queue, used only while the client is not keeping up."""

    __slots__ = ("prefix", "queue", "size", "topic")

    def __init__(self, topic: str, size: int) -> None:
        self.topic = topic
        dest = topic.encode()
        self.prefix = _pack_u32(len(dest)) + dest
        self.queue: deque[bytes] = deque()
        self.size = max(1, size)


class ClientSession(asyncio.BufferedProtocol):
    """Protocol state, registrations and bounded output of one TCP client."""

    def __init__(self, server: EndpointServer) -> None:
        self.server = server
        self.options = server.options
        self.memory = server.budget.share()
        decoder = FrameDecoder(
            server.options.max_frame_size,
            max_command=MAX_COMMAND_SIZE,
            reserve=self.memory.take,
            release=self.memory.give,
            lend_large=server.backend.lends_large_payloads,
        )
        self.proto = ProtocolConnection("endpoint", decoder=decoder)
        self._decoder = decoder
        self._recycle = decoder.recycle if server.backend.releases_lent_payloads else None
        """Gives a published lent payload back to the decoder, for the next large frame."""
        self.stats = SessionStats()
        self.peer = "?"
        self.transport: asyncio.Transport | None = None
        self.publishers: dict[str, tuple[str, BackendPublisher]] = {}
        self.subscriptions: dict[str, tuple[BackendSubscription, _Outbox]] = {}
        self.ros_services: dict[str, str] = {}
        self.unity_services: dict[str, tuple[str, BackendServiceServer]] = {}
        self._pending: dict[int, asyncio.Future[bytes]] = {}
        self._srv_ids = itertools.count(FIRST_SRV_ID)
        self._tasks: set[asyncio.Task[None]] = set()
        self.actions = SessionActions(self)
        self._out: list[bytes | memoryview] = []
        self._discard = bytearray(4096)
        self._out_size = 0
        self._fd = -1
        """The socket's descriptor, for scatter-gather writes while the transport is idle."""
        self._flush_scheduled = False
        self._writes = deferred_writes(server.loop)
        """Writes leave at the end of the read that caused them (or of the loop iteration)."""
        self._paused = False
        self._paused_at = 0.0
        opts = server.options
        self._gate = ReadGate()
        """Reading this client's socket, paused by back-pressure or while a splice reads it."""
        self._splices = opts.splice and server.backend.splices_large_payloads and can_splice()
        self._relay: SpliceRelay | None = None
        self._splice_fd = -1
        """A duplicate of the socket's descriptor: a relay's reader (the transport owns the
        original's)."""
        self._pushback = ReadPushback(
            server.loop, pushback_limit(opts.idle_timeout, opts.frame_timeout)
        )
        """Stops reading this client while ROS is behind on a topic it publishes that may
        not drop (queue_size 0)."""
        self._control: deque[bytes] = deque()
        self._backlogged: dict[str, _Outbox] = {}
        self._closing = False
        now = time.monotonic()
        self.last_recv = now
        self.last_sent = now
        self.connected_at = now
        self.proven = False
        """Whether the client has sent a complete frame other than a keepalive."""
        self.frame_started = 0.0
        """When the frame now partly received began to arrive (after the last complete one)."""
        self.frame_bytes = 0
        """`stats.bytes_in` when that frame began."""
        self._warn_scheduled = False
        self._reported_drops = 0
        self._unregistered_seen: dict[str, float] = {}
        self._unregistered_window = 0.0
        self._unregistered_errors = 0
        self._unregistered_suppressed = 0

    # ---- asyncio.Protocol ------------------------------------------------------------

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        assert isinstance(transport, asyncio.Transport)
        self.transport = transport
        self._gate.transport = transport
        self._pushback.transport = self._gate.holder("pushback")
        sock = transport.get_extra_info("socket")
        if sock is not None:
            with contextlib.suppress(OSError):  # reset already: the first read says so
                tune_stream(sock)  # Nagle off; on loopback, unpaced sends to the client
            self._fd = sock.fileno()
        peer = transport.get_extra_info("peername")
        self.peer = f"{peer[0]}:{peer[1]}" if isinstance(peer, tuple) else str(peer)
        transport.set_write_buffer_limits(high=self.options.write_high_water)
        if len(self.server._sessions) >= self.options.max_clients and not self.server.evict_one():
            log.warning(
                "refusing client %s: %d clients connected", self.peer, self.options.max_clients
            )
            transport.write(
                ErrorMessage(
                    f"endpoint full: {self.options.max_clients} clients connected (the limit)"
                ).encode()
            )
            transport.close()
            return
        self.server._sessions.add(self)
        log.info("client %s connected", self.peer)
        meta = {
            "protocol": self.server.backend.protocol,
            "keepalive": self.options.keepalive_interval,
            "extensions": [*EXTENSIONS, *self.server.backend.extensions],
        }
        self._send_control(Handshake(metadata=meta).encode())

    def connection_lost(self, exc: Exception | None) -> None:
        self._closing = True
        self.server._sessions.discard(self)
        log.info("client %s disconnected%s", self.peer, f" ({exc})" if exc else "")
        self._release_all()
        self._pushback.close()
        if self._relay is not None:
            self._relay.cancel()
            self._relay = None
        if self._splice_fd >= 0:
            os.close(self._splice_fd)
            self._splice_fd = -1
        self.proto.decoder.discard()
        self._control.clear()
        self._backlogged.clear()
        self.memory.release()

    def pause_writing(self) -> None:
        self._paused = True
        self._paused_at = time.monotonic()

    def resume_writing(self) -> None:
        self._paused = False
        self._drain_backlog()
        if not self._paused:
            for subscription, _ in list(self.subscriptions.values()):
                subscription.unblocked()

    def _blocked(self, outbox: _Outbox) -> bool:
        """Whether the backend should stop taking `outbox`'s topic from the graph: the
        client is not reading and its queue is half full, for at most _BLOCK_LIMIT seconds
        (past that the client is slow, not momentarily busy, and drops are its own)."""
        if not self._paused or len(outbox.queue) * 2 < outbox.size:
            return False
        return time.monotonic() - self._paused_at < _BLOCK_LIMIT

    def get_buffer(self, sizehint: int) -> memoryview:
        if self.proto.closed:
            return memoryview(self._discard)
        return self._decoder.get_buffer()

    def buffer_updated(self, nbytes: int) -> None:
        writes = self._writes
        writes.hold()
        try:
            self._received(nbytes)
            if self._splices:
                self._splice_next()
        finally:
            writes.release()

    def _splice_next(self) -> None:
        """When a large message is next on the socket and its topic's only subscriber can
        take it, move it there by splice while reading is paused (`endpoint.speed.splice`)."""
        waiting = self.proto.waiting_message()
        if waiting is None or self._closing or self._relay is not None or self._fd < 0:
            return
        entry = self.publishers.get(waiting[0])
        sink = entry[1].splice_sink() if entry is not None else None
        if sink is None:
            return
        if self._splice_fd < 0:
            self._splice_fd = os.dup(self._fd)
        loop, fd, buffer = self.server.loop, self._splice_fd, waiting[1]
        relay = SpliceRelay(loop, fd, buffer, sink, done=self._spliced, moved=self._moved)
        self._gate.pause("splice")
        self._relay = relay
        if not relay.start():
            self._relay = None
            self._gate.resume("splice")

    def _moved(self, nbytes: int) -> None:
        self.stats.bytes_in += nbytes
        self.last_recv = time.monotonic()

    def _spliced(self, whole: bool, buffer_taken: bool) -> None:
        self._relay = None
        if not whole:  # the client left (or its socket failed) in the middle of a message
            if self.transport is not None:
                self.transport.abort()
            return
        self.proto.message_moved(taken=buffer_taken)
        self.stats.frames_in += 1
        self.frame_started = 0.0
        self.proven = True
        self._gate.resume("splice")

    def _received(self, nbytes: int) -> None:
        """Handle the frames `nbytes` more bytes complete (what they make the endpoint
        write, to this client or to ROS, leaves when the caller releases the writes)."""
        now = self.last_recv = time.monotonic()
        stats = self.stats
        stats.bytes_in += nbytes
        publishers = self.publishers
        events: list[Event]
        burst = self.proto.message_runs(nbytes)
        if burst is not None:
            # The commonest reads, messages on the topic of the frame before them (one
            # command a step, a ping, a burst): published in one loop, without frame and
            # event objects, as the loop below would publish them.
            entry = publishers.get(burst[0])
            if entry is not None and not self._closing:
                self._publish_burst(burst[0], entry[1], burst[1], now)
                return
            events = [MessageReceived(burst[0], payload) for payload in burst[1]]
        else:
            events = self.proto.buffer_updated(nbytes)
        if events or not self.frame_started:
            # Slow-sender clock: restarts whenever a frame completes.
            if self._decoder.partial:
                self.frame_started, self.frame_bytes = now, stats.bytes_in
            else:
                self.frame_started = 0.0
        recycle = self._recycle
        for event in events:
            if self._closing:
                break
            stats.frames_in += 1
            try:
                if type(event) is MessageReceived:
                    entry = publishers.get(event.topic)
                    if entry is not None:
                        payload = event.payload
                        entry[1].publish(payload)
                        if recycle is not None and type(payload) is bytearray:
                            recycle(payload)
                    else:
                        self._unregistered(event.topic)
                elif type(event) is KeepaliveReceived:
                    continue
                else:
                    self._handle_event(event)
                self.proven = True
            except Exception as exc:  # one bad request must not drop the client
                self._internal_error(event, exc)

    def _publish_burst(
        self, topic: str, publisher: BackendPublisher, payloads: list[bytes], now: float
    ) -> None:
        """`_received`'s loop for a read of messages on one registered topic (small ones,
        `bytes`: nothing to recycle); a failed publish is reported as there and the rest
        still go out."""
        stats = self.stats
        if self._decoder.partial:  # slow-sender clock, as for any read that completes frames
            self.frame_started, self.frame_bytes = now, stats.bytes_in
        else:
            self.frame_started = 0.0
        publish = publisher.publish
        published = False
        for payload in payloads:
            if self._closing:
                break
            stats.frames_in += 1
            try:
                publish(payload)
                published = True
            except Exception as exc:  # one bad request must not drop the client
                self._internal_error(MessageReceived(topic, payload), exc)
        if published:
            self.proven = True

    def _internal_error(self, event: object, exc: Exception) -> None:
        """An unexpected exception while handling `event`: an `__error` naming the
        request, the full traceback in the log; the connection stays up."""
        if isinstance(event, CommandReceived):
            what = event.command.NAME
        elif isinstance(event, MessageReceived):
            what = f"message on {shorten(event.topic)}"
        elif isinstance(event, ServiceRequestReceived | ServiceResponseReceived):
            what = f"service frame {shorten(event.service)} (srv_id {event.srv_id})"
        else:
            what = type(event).__name__
        log.error("client %s: %s failed", self.peer, what, exc_info=exc)
        srv_id = event.srv_id if isinstance(event, ServiceRequestReceived) else None
        self.send_error(f"{what} failed: {type(exc).__name__}: {shorten(str(exc), 200)}", srv_id)

    # ---- output ---------------------------------------------------------------------

    def _write(self, chunk: bytes | memoryview) -> None:
        self._out.append(chunk)
        self._out_size += len(chunk)
        if self._out_size >= self.options.write_high_water:
            self._flush()
        elif not self._flush_scheduled:
            self._flush_scheduled = True
            self._writes.defer(self._flush)

    def _flush(self) -> None:
        self._flush_scheduled = False
        out, self._out = self._out, []
        size, self._out_size = self._out_size, 0
        transport = self.transport
        if not out or transport is None or transport.is_closing():
            return
        self.last_sent = time.monotonic()
        self.stats.bytes_out += size
        write_chunks(transport, self._fd, out)

    def _send_control(self, frame: bytes) -> None:
        """Send a frame that must not be dropped (handshake, service frames, errors)."""
        if self._closing:
            return
        self.stats.frames_out += 1
        if not self._paused:
            self._write(frame)
            return
        if len(self._control) >= self.options.max_control_backlog or not self.memory.take(
            len(frame)
        ):
            log.error(
                "client %s stopped reading; %d control frames (%d bytes held) queued, "
                "disconnecting",
                self.peer,
                len(self._control),
                self.memory.held,
            )
            self.close()
            return
        self._control.append(frame)

    def deliver(self, outbox: _Outbox, payload: bytes) -> None:
        """Queue one subscribed message, dropping the oldest when the client lags."""
        if self._closing:
            return
        if not self._paused:
            self.stats.frames_out += 1
            size = len(payload)
            if size < WRITE_ALONE:
                self._write(outbox.prefix + _pack_u32(size) + payload)
            else:
                self._write(outbox.prefix + _pack_u32(size))
                self._write(payload)
            return
        queue = outbox.queue
        memory = self.memory
        size = len(payload) + _ENTRY_OVERHEAD
        while queue and (len(queue) >= outbox.size or not memory.fits(size)):
            memory.give(len(queue.popleft()) + _ENTRY_OVERHEAD)
            self._dropped(outbox.topic)
        if not memory.take(size):
            self._dropped(outbox.topic)  # alone it does not fit this client's share
            return
        queue.append(payload)
        self._backlogged[outbox.topic] = outbox

    def deliver_lent(self, outbox: _Outbox, view: memoryview) -> None:
        """`deliver` for a payload the backend lends for this call only (it reuses the
        memory afterwards). While the client reads, a large one is written now, straight
        from the view (what the kernel does not take at once goes to the transport's
        buffer, copied); anything kept for later is copied first."""
        size = len(view)
        if self._paused or self._closing or size < WRITE_ALONE:
            self.deliver(outbox, bytes(view))
            return
        self.stats.frames_out += 1
        self._write(outbox.prefix + _pack_u32(size))
        self._write(view)
        self._flush()

    def deliver_many(self, outbox: _Outbox, payloads: Sequence[bytes]) -> int:
        """Queue subscribed messages that arrived together; returns how many it took. While
        the client reads, small ones leave as one joined chunk (one frame header built for
        a run of one size); otherwise each goes through `deliver`, stopping once the topic
        should push back on its publishers (`_blocked`)."""
        if not payloads:
            return 0
        if not self._paused and not self._closing:
            sizes = set(map(len, payloads))
            if max(sizes) < WRITE_ALONE:
                self.stats.frames_out += len(payloads)
                prefix = outbox.prefix
                if len(sizes) == 1:
                    head = prefix + _pack_u32(sizes.pop())
                    self._write(head + head.join(payloads))
                else:
                    self._write(b"".join([prefix + _pack_u32(len(p)) + p for p in payloads]))
                return len(payloads)
        taken = 0
        for payload in payloads:
            self.deliver(outbox, payload)
            taken += 1
            if self._blocked(outbox):
                break
        return taken

    def _dropped(self, topic: str) -> None:
        self.stats.dropped[topic] += 1
        if not self._warn_scheduled:
            self._warn_scheduled = True
            self.server.loop.call_later(self.options.warn_interval, self._warn_drops)

    def _drain_backlog(self) -> None:
        while self._control and not self._paused:
            frame = self._control.popleft()
            self.memory.give(len(frame))
            self._write(frame)
        while self._backlogged and not self._paused:
            for key, outbox in list(self._backlogged.items()):
                if self._paused:
                    break
                if outbox.queue:
                    payload = outbox.queue.popleft()
                    self.memory.give(len(payload) + _ENTRY_OVERHEAD)
                    self.stats.frames_out += 1
                    self._write(outbox.prefix + _pack_u32(len(payload)))
                    self._write(payload)
                    self._flush()
                if not outbox.queue:
                    del self._backlogged[key]

    def _warn_drops(self) -> None:
        """One `__warn` per interval with every drop since the last one."""
        self._warn_scheduled = False
        total = sum(self.stats.dropped.values())
        new = total - self._reported_drops
        if not new or self._closing:
            return
        self._reported_drops = total
        detail = ", ".join(f"{shorten(t)}: {n}" for t, n in self.stats.dropped.most_common(5))
        self._send_control(
            WarnMessage(
                f"client is not keeping up: dropped {new} message(s) since the last warning "
                f"({total} in all; per topic {detail}); raise queue_size or read faster"
            ).encode()
        )

    def send_error(
        self, text: str, srv_id: int | None = None, *, goal_id: int | None = None
    ) -> None:
        """Report a bad request to the client and the log (cut to `_MAX_ERROR_TEXT`); with
        `srv_id` it fails that service call, with `goal_id` that action goal."""
        if len(text) > _MAX_ERROR_TEXT:
            text = f"{text[:_MAX_ERROR_TEXT]}... ({len(text):,} characters, truncated)"
        self.stats.errors_sent += 1
        log.warning("client %s: %s", self.peer, text)
        self._send_control(ErrorMessage(text, srv_id, goal_id).encode())

    def send_keepalive_if_idle(self, now: float) -> None:
        """Called by the server's timer."""
        if now - self.last_sent >= self.options.keepalive_interval and not self._paused:
            self._write(KEEPALIVE)
            self.last_sent = now

    def close(self) -> None:
        """Drop the connection, after handing the transport what is queued (a last __error);
        nothing more is read from or queued for it."""
        self._closing = True
        if self.transport is not None:
            self._flush()
            self.transport.close()

    # ---- events -----------------------------------------------------------------------

    def _unregistered(self, topic: str) -> None:
        """An `__error` per topic per interval, and at most `max_errors_per_interval` of
        them per client; the rest are counted and summed up in the next one."""
        now = time.monotonic()
        opts = self.options
        if now - self._unregistered_seen.get(topic, -1e9) < opts.warn_interval:
            return
        if now - self._unregistered_window >= opts.warn_interval:
            self._unregistered_window, self._unregistered_errors = now, 0
        if self._unregistered_errors >= opts.max_errors_per_interval:
            self._unregistered_suppressed += 1
            return
        self._unregistered_errors += 1
        if len(self._unregistered_seen) >= _MAX_REMEMBERED:
            self._unregistered_seen.clear()
        self._unregistered_seen[topic] = now
        suppressed = ""
        if self._unregistered_suppressed:
            suppressed = (
                f" ({self._unregistered_suppressed} more messages on unregistered topics "
                "were not reported)"
            )
            self._unregistered_suppressed = 0
        if topic in self.ros_services or topic in self.unity_services:
            hint = "a service frame must follow a __request or __response header"
        else:
            hint = "send __publish for it first"
        self.send_error(
            f"message on {shorten(topic)}, which is not registered for publishing; {hint}"
            + suppressed
        )

    def _handle_event(self, event: object) -> None:
        if isinstance(event, CommandReceived):
            try:
                self._handle_command(event.command)
            except SimbridgeError as exc:
                self.send_error(f"{event.command.NAME} failed: {exc}")
        elif isinstance(event, ServiceRequestReceived):
            if len(self._tasks) >= self.options.max_inflight_calls:
                self.send_error(
                    f"call of {shorten(event.service)} (srv_id {event.srv_id}) refused: "
                    f"{len(self._tasks)} calls already in flight (limit "
                    f"{self.options.max_inflight_calls}); wait for answers first",
                    event.srv_id,
                )
            else:
                self._spawn(self._serve_client_request(event))
        elif isinstance(event, ServiceResponseReceived):
            future = self._pending.pop(event.srv_id, None)
            if future is None:
                self.send_error(
                    f"__response for unknown srv_id {event.srv_id} ({shorten(event.service)})"
                )
            elif not future.done():
                future.set_result(event.payload)
        elif isinstance(event, ProtocolViolation):
            self.send_error(event.text)
            if event.fatal:
                self.close()

    def _registrations(self) -> int:
        return (
            len(self.publishers)
            + len(self.subscriptions)
            + len(self.ros_services)
            + len(self.unity_services)
        )

    def _check_room(self, topic: str, held: Mapping[str, object]) -> None:
        limit = self.options.max_registrations
        if topic not in held and self._registrations() >= limit:
            raise EndpointError(
                f"{shorten(topic)} not registered: this client already holds {limit} registrations "
                "(the limit); remove some with __remove_* first"
            )

    def _handle_command(self, command: Command) -> None:
        types = self.server.types
        backend = self.server.backend
        if isinstance(command, Publish):
            self._check_room(command.topic, self.publishers)
            msg_type = types.message(command.message_name)
            self._drop_publisher(command.topic)
            publisher = backend.advertise(
                command.topic, msg_type, queue_size=command.queue_size, latch=command.latch
            )
            self.publishers[command.topic] = (msg_type, publisher)
            self._unregistered_seen.pop(command.topic, None)
            pushback = self._pushback
            publisher.watch_backlog(
                functools.partial(pushback.behind, publisher),
                functools.partial(pushback.caught_up, publisher),
            )
            if command.report_subscribers:
                topic = command.topic
                send = self._send_control
                if not publisher.watch_subscribers(
                    lambda count: send(SubscriberCount(topic, count).encode())
                ):
                    send(SubscriberCount(topic, -1).encode())
        elif isinstance(command, Subscribe):
            self._check_room(command.topic, self.subscriptions)
            msg_type = types.message(command.message_name)
            self._drop_subscription(command.topic)
            outbox = _Outbox(command.topic, command.queue_size)
            # partial, not lambda: one Python frame less per message relayed
            subscription = backend.subscribe(
                command.topic, msg_type, functools.partial(self.deliver, outbox)
            )
            subscription.throttle(functools.partial(self._blocked, outbox))
            subscription.batches(functools.partial(self.deliver_many, outbox))
            subscription.lends(functools.partial(self.deliver_lent, outbox))
            self.subscriptions[command.topic] = (subscription, outbox)
        elif isinstance(command, RosService):
            self._check_room(command.topic, self.ros_services)
            self.ros_services[command.topic] = types.service(command.message_name)
        elif isinstance(command, UnityService):
            self._check_room(command.topic, self.unity_services)
            srv_type = types.service(command.message_name)
            self._drop_unity_service(command.topic)
            server = backend.advertise_service(
                command.topic, srv_type, self._make_unity_handler(command.topic)
            )
            self.unity_services[command.topic] = (srv_type, server)
        elif isinstance(command, RemovePublisher):
            self._drop_publisher(command.topic)
        elif isinstance(command, RemoveSubscriber):
            self._drop_subscription(command.topic)
        elif isinstance(command, RemoveRosService):
            self.ros_services.pop(command.topic, None)
        elif isinstance(command, RemoveUnityService):
            self._drop_unity_service(command.topic)
        elif isinstance(command, TopicListRequest):
            infos = backend.topics()
            reply = TopicListReply(tuple(t.name for t in infos), tuple(t.msg_type for t in infos))
            self._send_control(reply.encode())
        elif isinstance(command, ServiceFailure):
            future = self._pending.pop(command.srv_id, None)
            if future is None:
                self.send_error(f"__service_error for unknown srv_id {command.srv_id}")
            elif not future.done():
                future.set_exception(
                    ServiceError(
                        f"the service handler in client {self.peer} failed: {command.text}"
                    )
                )
        elif isinstance(command, ActionGoal | ActionCancel | ActionServerQuery):
            self.actions.handle(command)
        elif isinstance(command, SetParam):
            if len(self._tasks) >= self.options.max_inflight_calls:
                raise EndpointError(
                    f"{shorten(command.name)} not set: {len(self._tasks)} requests already in "
                    f"flight (limit {self.options.max_inflight_calls}); wait for them first"
                )
            self._spawn(self._set_param(command))
        elif isinstance(command, StatsRequest):
            stats = {"session": self.stats.as_dict(), "server": self.server.stats()}
            self._send_control(StatsReply(stats).encode())
        else:
            self.send_error(f"{command.NAME} is not something a client sends")

    async def _set_param(self, command: SetParam) -> None:
        """`__set_param`: the backend sets it (the ROS 1 master is a round trip away, so
        this runs as a task); a failure is an `__error` naming the parameter."""
        try:
            await self.server.backend.set_param(command.name, command.value)
        except SimbridgeError as exc:
            self.send_error(f"__set_param {shorten(command.name)} failed: {exc}")
            return
        log.info("client %s set parameter %s", self.peer, shorten(command.name))

    # ---- services -----------------------------------------------------------------------

    def _spawn(self, coro: Coroutine[Any, Any, None]) -> None:
        task = asyncio.ensure_future(coro)
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)

    async def _serve_client_request(self, event: ServiceRequestReceived) -> None:
        srv_type = self.ros_services.get(event.service)
        if srv_type is None:
            self.send_error(
                f"service {shorten(event.service)} was not registered with __ros_service; "
                "register it before calling",
                event.srv_id,
            )
            return
        try:
            response = await self.server.backend.call_service(
                event.service, srv_type, event.payload, timeout=self.options.service_timeout
            )
        except SimbridgeError as exc:
            self.send_error(
                f"call of {shorten(event.service)} (srv_id {event.srv_id}) failed: {exc}",
                event.srv_id,
            )
            return
        except Exception as exc:
            log.exception("service %s failed", event.service)
            self.send_error(f"call of {shorten(event.service)} failed: {exc!r}", event.srv_id)
            return
        self._send_control(
            ProtocolConnection.service_response(event.srv_id, event.service, response)
        )

    def _make_unity_handler(self, service: str) -> Callable[[bytes], Awaitable[bytes]]:
        async def handler(request: bytes) -> bytes:
            return await self._call_client(service, request)

        return handler

    async def _call_client(self, service: str, request: bytes) -> bytes:
        if self._closing:
            raise ServiceError(f"the client implementing {shorten(service)} has disconnected")
        srv_id = next(self._srv_ids)
        future: asyncio.Future[bytes] = self.server.loop.create_future()
        self._pending[srv_id] = future
        self._send_control(ProtocolConnection.service_request(srv_id, service, request))
        try:
            return await asyncio.wait_for(future, self.options.service_timeout)
        except TimeoutError:
            raise ServiceError(
                f"client {self.peer} did not answer {shorten(service)} within "
                f"{self.options.service_timeout:g} s"
            ) from None
        finally:
            self._pending.pop(srv_id, None)

    # ---- registrations ----------------------------------------------------------------

    def _drop_publisher(self, topic: str) -> None:
        entry = self.publishers.pop(topic, None)
        if entry is not None:
            entry[1].close()
            self._pushback.caught_up(entry[1])

    def _drop_subscription(self, topic: str) -> None:
        entry = self.subscriptions.pop(topic, None)
        if entry is not None:
            entry[0].close()
            self._backlogged.pop(topic, None)
            queue = entry[1].queue
            self.memory.give(sum(map(len, queue)) + _ENTRY_OVERHEAD * len(queue))
            queue.clear()

    def _drop_unity_service(self, topic: str) -> None:
        entry = self.unity_services.pop(topic, None)
        if entry is not None:
            entry[1].close()

    def _release_all(self) -> None:
        self.actions.close()
        for topic in list(self.publishers):
            self._drop_publisher(topic)
        for topic in list(self.subscriptions):
            self._drop_subscription(topic)
        for topic in list(self.unity_services):
            self._drop_unity_service(topic)
        self.ros_services.clear()
        for future in self._pending.values():
            if not future.done():
                future.set_exception(ServiceError(f"client {self.peer} disconnected"))
        self._pending.clear()
        for task in list(self._tasks):
            task.cancel()
