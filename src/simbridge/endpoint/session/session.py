"""One client connection of the endpoint: its frames in, its registrations and its bounded
output (its action goals and service calls are `actions` and `services` beside it)."""

from __future__ import annotations

import asyncio
import contextlib
import functools
import logging
import os
import time
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any, Protocol

from simbridge.endpoint.backends.base import (
    BackendPublisher,
    BackendServiceServer,
    BackendSubscription,
)
from simbridge.endpoint.session.actions import ACTION_COMMANDS, SessionActions
from simbridge.endpoint.session.output import ClientOutput, Outbox
from simbridge.endpoint.session.pushback import ReadGate, ReadPushback, pushback_limit
from simbridge.endpoint.session.services import SessionServices
from simbridge.endpoint.session.stats import SessionStats
from simbridge.endpoint.session.unregistered import UnregisteredReports
from simbridge.endpoint.speed.deferred import deferred_writes
from simbridge.endpoint.speed.splice import SpliceRelay, can_splice
from simbridge.errors import EndpointError, SimbridgeError
from simbridge.protocol import (
    EXTENSIONS,
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
    shorten,
)
from simbridge.protocol.commands import MAX_COMMAND_SIZE, Command
from simbridge.protocol.framing import FrameDecoder
from simbridge.tcp import tune_stream

if TYPE_CHECKING:
    from simbridge.endpoint.backends.base import Backend
    from simbridge.endpoint.budget import MemoryBudget
    from simbridge.endpoint.options import EndpointOptions
    from simbridge.endpoint.typecheck import TypeCheck

__all__ = ["ClientSession", "SessionHost"]

log = logging.getLogger("simbridge.endpoint")
_MAX_ERROR_TEXT = 1000
"""Longest `__error` text (and log line) sent; every echoed name is already shortened."""


class SessionHost(Protocol):
    """What a client session needs of the server that accepted its connection."""

    @property
    def options(self) -> EndpointOptions:
        """The endpoint's settings."""
        ...

    @property
    def backend(self) -> Backend:
        """The graph the client's traffic goes to."""
        ...

    @property
    def types(self) -> TypeCheck:
        """Checks the type names the client registers."""
        ...

    @property
    def budget(self) -> MemoryBudget:
        """The server-wide memory budget, of which the session takes a share."""
        ...

    @property
    def loop(self) -> asyncio.AbstractEventLoop:
        """The loop the server runs on."""
        ...

    def admit(self, session: ClientSession) -> bool:
        """Count `session` among the connected clients; False when the server is full."""
        ...

    def forget(self, session: ClientSession) -> None:
        """`session`'s connection is gone."""

    def drain(self, peer: str, publishers: list[tuple[str, BackendPublisher]]) -> None:
        """Deliver what each `(topic, publisher)` of client `peer` accepted, then close it
        (in the background: `endpoint.session.drain`)."""

    def stats(self) -> dict[str, Any]:
        """Server-wide counters, for `__stats`."""
        ...


class ClientSession(asyncio.BufferedProtocol):
    """Protocol state, registrations and bounded output of one TCP client."""

    def __init__(self, server: SessionHost) -> None:
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
        self.subscriptions: dict[str, tuple[BackendSubscription, Outbox]] = {}
        self.ros_services: dict[str, str] = {}
        self.unity_services: dict[str, tuple[str, BackendServiceServer]] = {}
        self.services = SessionServices(self, server.backend, server.options, server.loop)
        self.actions = SessionActions(self, server.backend, server.options)
        self.output = ClientOutput(server.options, self.memory, self.stats, server.loop, self.close)
        self._discard = bytearray(4096)
        self._fd = -1
        """The socket's descriptor (the output's scatter-gather writes; a splice's duplicate)."""
        self._writes = deferred_writes(server.loop)
        """Writes leave at the end of the read that caused them (`ClientOutput`)."""
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
        self._closing = False
        now = time.monotonic()
        self.last_recv = now
        self.connected_at = now
        self.proven = False
        """Whether the client has sent a complete frame other than a keepalive."""
        self.frame_started = 0.0
        """When the frame now partly received began to arrive (after the last complete one)."""
        self.frame_bytes = 0
        """`stats.bytes_in` when that frame began."""
        self.unregistered = UnregisteredReports(opts.warn_interval, opts.max_errors_per_interval)
        """Rate limit of the errors about messages on topics the client did not register."""

    @property
    def closing(self) -> bool:
        """Whether the connection is going away: nothing more is read from or sent to it."""
        return self._closing

    @property
    def writing_paused(self) -> bool:
        """Whether the transport asked to stop writing (the client is not reading)."""
        return self.output.paused

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
        self.peer = f"{peer[0]}:{peer[1]}" if isinstance(peer, tuple) else str(peer) or "in-process"
        self.output.attach(transport, self._fd, self.peer)
        transport.set_write_buffer_limits(high=self.options.write_high_water)
        if not self.server.admit(self):
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
        log.info("client %s connected", self.peer)
        meta = {
            "protocol": self.server.backend.protocol,
            "keepalive": self.options.keepalive_interval,
            "extensions": [*EXTENSIONS, *self.server.backend.extensions],
        }
        self.send_control(Handshake(metadata=meta).encode())

    def connection_lost(self, exc: Exception | None) -> None:
        self._closing = True
        self.output.stop()
        self.server.forget(self)
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
        self.output.discard()
        self.memory.release()

    def pause_writing(self) -> None:
        self.output.pause()

    def resume_writing(self) -> None:
        if self.output.resume():
            for subscription, _ in list(self.subscriptions.values()):
                subscription.unblocked()

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
                        stats.published[event.topic] += 1
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
        published = 0
        for payload in payloads:
            if self._closing:
                break
            stats.frames_in += 1
            try:
                publish(payload)
                published += 1
            except Exception as exc:  # one bad request must not drop the client
                self._internal_error(MessageReceived(topic, payload), exc)
        if published:
            stats.published[topic] += published
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

    def send_control(self, frame: bytes) -> None:
        """Send a frame that must not be dropped (handshake, service frames, errors)."""
        self.output.send_control(frame)

    def send_error(
        self, text: str, srv_id: int | None = None, *, goal_id: int | None = None
    ) -> None:
        """Report a bad request to the client and the log (cut to `_MAX_ERROR_TEXT`); with
        `srv_id` it fails that service call, with `goal_id` that action goal."""
        if len(text) > _MAX_ERROR_TEXT:
            text = f"{text[:_MAX_ERROR_TEXT]}... ({len(text):,} characters, truncated)"
        self.stats.errors_sent += 1
        log.warning("client %s: %s", self.peer, text)
        self.send_control(ErrorMessage(text, srv_id, goal_id).encode())

    def send_keepalive_if_idle(self, now: float) -> None:
        """Called by the server's timer."""
        self.output.send_keepalive_if_idle(now)

    def close(self) -> None:
        """Drop the connection, after handing the transport what is queued (a last __error);
        nothing more is read from or queued for it."""
        self._closing = True
        self.output.close()

    # ---- events -----------------------------------------------------------------------

    def _unregistered(self, topic: str) -> None:
        """An `__error` about a message on a topic the client did not register, unless the
        rate limit leaves it out (`UnregisteredReports`)."""
        left_out = self.unregistered.due(topic, time.monotonic())
        if left_out is None:
            return
        if topic in self.ros_services or topic in self.unity_services:
            hint = "a service frame must follow a __request or __response header"
        else:
            hint = "send __publish for it first"
        self.send_error(
            f"message on {shorten(topic)}, which is not registered for publishing; {hint}"
            + left_out
        )

    def _handle_event(self, event: object) -> None:
        if isinstance(event, CommandReceived):
            try:
                self._handle_command(event.command)
            except SimbridgeError as exc:
                self.send_error(f"{event.command.NAME} failed: {exc}")
        elif isinstance(event, ServiceRequestReceived):
            self.services.call(event)
        elif isinstance(event, ServiceResponseReceived):
            self.services.answered(event.srv_id, event.service, event.payload)
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
            self.unregistered.forget(command.topic)
            pushback = self._pushback
            publisher.watch_backlog(
                functools.partial(pushback.behind, publisher),
                functools.partial(pushback.caught_up, publisher),
            )
            if command.report_subscribers:
                topic = command.topic
                send = self.send_control
                if not publisher.watch_subscribers(
                    lambda count: send(SubscriberCount(topic, count).encode())
                ):
                    send(SubscriberCount(topic, -1).encode())
        elif isinstance(command, Subscribe):
            self._check_room(command.topic, self.subscriptions)
            msg_type = types.message(command.message_name)
            self._drop_subscription(command.topic)
            outbox = Outbox(command.topic, command.queue_size)
            # partial, not lambda: one Python frame less per message relayed
            output = self.output
            subscription = backend.subscribe(
                command.topic, msg_type, functools.partial(output.deliver, outbox)
            )
            subscription.throttle(functools.partial(output.blocked, outbox))
            subscription.batches(functools.partial(output.deliver_many, outbox))
            subscription.lends(functools.partial(output.deliver_lent, outbox))
            self.subscriptions[command.topic] = (subscription, outbox)
        elif isinstance(command, RosService):
            self._check_room(command.topic, self.ros_services)
            srv_type = types.service(command.message_name)
            self.services.open_caller(command.topic, srv_type)
            self.ros_services[command.topic] = srv_type
        elif isinstance(command, UnityService):
            self._check_room(command.topic, self.unity_services)
            srv_type = types.service(command.message_name)
            self._drop_unity_service(command.topic)
            server = backend.advertise_service(
                command.topic, srv_type, self.services.handler(command.topic)
            )
            self.unity_services[command.topic] = (srv_type, server)
        elif isinstance(command, RemovePublisher):
            self._drop_publisher(command.topic)
        elif isinstance(command, RemoveSubscriber):
            self._drop_subscription(command.topic)
        elif isinstance(command, RemoveRosService):
            self.ros_services.pop(command.topic, None)
            self.services.close_caller(command.topic)
        elif isinstance(command, RemoveUnityService):
            self._drop_unity_service(command.topic)
        elif isinstance(command, TopicListRequest):
            infos = backend.topics()
            reply = TopicListReply(tuple(t.name for t in infos), tuple(t.msg_type for t in infos))
            self.send_control(reply.encode())
        elif isinstance(command, ServiceFailure):
            self.services.failed(command)
        elif isinstance(command, ACTION_COMMANDS):
            self.actions.handle(command)
        elif isinstance(command, SetParam):
            self.services.set_param(command)
        elif isinstance(command, StatsRequest):
            stats = {"session": self.stats.as_dict(), "server": self.server.stats()}
            self.send_control(StatsReply(stats).encode())
        else:
            self.send_error(f"{command.NAME} is not something a client sends")

    # ---- registrations ----------------------------------------------------------------

    def _drop_publisher(self, topic: str) -> None:
        """Stop publishing `topic` for this client; what it accepted is delivered first
        (`SessionHost.drain`)."""
        entry = self.publishers.pop(topic, None)
        if entry is not None:
            self._pushback.caught_up(entry[1])
            self.server.drain(self.peer, [(topic, entry[1])])

    def _drop_subscription(self, topic: str) -> None:
        entry = self.subscriptions.pop(topic, None)
        if entry is not None:
            entry[0].close()
            self.output.drop(entry[1])

    def _drop_unity_service(self, topic: str) -> None:
        entry = self.unity_services.pop(topic, None)
        if entry is not None:
            entry[1].close()

    def _release_all(self) -> None:
        self.actions.close()
        publishers = [(topic, entry[1]) for topic, entry in self.publishers.items()]
        self.publishers.clear()
        self.server.drain(self.peer, publishers)
        for topic in list(self.subscriptions):
            self._drop_subscription(topic)
        for topic in list(self.unity_services):
            self._drop_unity_service(topic)
        self.ros_services.clear()
        self.services.close()
