"""The simulation-side ROS-TCP client, with the abilities of Unity's ROSConnection.

`Connector` is the public API; the threads and connection handling live in
`ConnectorEngine`.
"""

from __future__ import annotations

import asyncio
import json
import logging
import time
from collections import deque
from concurrent.futures import Future
from concurrent.futures import TimeoutError as FutureTimeoutError
from types import TracebackType
from typing import TYPE_CHECKING, Any

from simbridge.connector.batch import PublishBatch
from simbridge.connector.calls import PendingCall, ServiceHandler, ServiceImpl
from simbridge.connector.codec import is_raw
from simbridge.connector.engine import ConnectorEngine
from simbridge.connector.handles import MessageCallback, MessageTap, Publisher, Subscription
from simbridge.connector.served import ServedHandler
from simbridge.connector.stats import ConnectorStats
from simbridge.connector.writer import OutTopic
from simbridge.errors import ConnectorError, ServiceError
from simbridge.protocol import (
    ACTION_SERVERS_EXTENSION,
    MAX_COMMAND_SIZE,
    Command,
    RemovePublisher,
    RemoveRosService,
    RemoveSubscriber,
    RemoveUnityService,
    RosService,
    ServeAction,
    SetParam,
    StatsRequest,
    TopicListRequest,
    UnityService,
    UnserveAction,
)

if TYPE_CHECKING:
    from simbridge.messages import MessageRegistry

__all__ = ["Connector"]

_log = logging.getLogger("simbridge.connector")


def _check_name(name: str, what: str) -> None:
    if not isinstance(name, str) or not name.strip():
        raise ConnectorError(f"{what} name {name!r} is blank; expected a name such as '/cmd_vel'")
    if any(c.isspace() for c in name):
        raise ConnectorError(f"{what} name {name!r} contains whitespace")
    if name.startswith("__"):
        raise ConnectorError(f"{what} name {name!r} starts with '__', reserved for system commands")


class Connector(ConnectorEngine):
    """A thread-based ROS-TCP client: publish, subscribe, call and implement services."""

    # ----------------------------------------------------------------- lifecycle

    def connect(self, wait: float | None = 5.0) -> Connector:
        """Start the I/O threads; with `wait`, block until connected (ConnectorError if not).

        Without `wait` it returns at once and connects in the background. Either way it
        keeps reconnecting on its own until `close()`.
        """
        with self._lock:
            if self._closing.is_set():
                raise ConnectorError("this connector was closed; create a new one")
            if not self._started:
                self._started = True
                self._writer.start()
                self._dispatcher.start()
        if wait is not None and not self.wait_connected(wait):
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
        dispatcher = self._dispatcher
        dispatcher.yield_io()  # called from a callback: the other worker drains
        if self._started and not dispatcher.holds_io and not dispatcher.wait_io_done(grace + 1.0):
            if link is not None:
                link.fail()
            dispatcher.wait_io_done(5.0)
        self._writer.stop()
        self._dispatcher.stop()
        with self._lock:
            unsent, self._unsent_calls = self._unsent_calls, []
        for call in unsent:
            call.fail(f"connector closed before {call.service} was called")

    def __enter__(self) -> Connector:
        if not self._started:
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

    @property
    def registry(self) -> MessageRegistry:
        """The registry message objects come from and go through: the one given, else the
        shared registry of the protocol in use (ROS 2 layouts once a ROS 2 endpoint's
        handshake arrived). Build messages with it to match the endpoint."""
        return self._codec.registry

    @property
    def extensions(self) -> frozenset[str]:
        """The simbridge protocol extensions the endpoint announced in its handshake (empty
        while not connected, and from endpoints without extensions such as Unity's)."""
        return self._extensions

    def wait_connected(self, timeout: float | None = None) -> bool:
        """Block until connected; False when `timeout` passed first."""
        if not self._connected.is_set():
            self._dispatcher.yield_io()  # from a callback: the other worker connects
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
        *,
        raw: bool = False,
    ) -> Publisher:
        """Advertise `topic`; returns the Publisher.

        With `report_subscribers`, an endpoint that offers the simbridge `subscribers`
        extension keeps `Publisher.subscriber_count` up to date (lazy sensors publish
        only while someone listens). Registering again replaces the registration;
        earlier Publisher objects of the topic keep working and share its queue.
        A `msg_type` the registry does not know raises ConnectorError at once, unless
        `raw` says only payload bytes will be published (a type only ROS knows).
        """
        _check_name(topic, "topic")
        _check_name(msg_type, "message type")
        if not raw:
            self._codec.check_type(msg_type, f"publisher {topic}")
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
                taps=self._taps,
                batch=self._batch,
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

    def add_tap(self, tap: MessageTap) -> None:
        """Show `tap` every payload published or received from now on, with its topic and
        type (a recorder's hook). It runs on the publishing or reader thread: never block."""
        with self._lock:
            if tap not in self._taps:
                self._taps.append(tap)

    def remove_tap(self, tap: MessageTap) -> None:
        """Stop showing messages to `tap`."""
        with self._lock:
            if tap in self._taps:
                self._taps.remove(tap)

    @property
    def wire_format(self) -> str:
        """How payloads are serialized right now: "ros1" or "cdr" (ROS 2)."""
        return "cdr" if self.protocol == "ROS2" else "ros1"

    def publish(self, topic: str, msg: object) -> None:
        """Queue a message on a registered topic; thread-safe and never blocks."""
        pub = self._publishers.get(topic)
        if pub is None:
            raise ConnectorError(
                f"no publisher registered on {topic!r}; call register_publisher first "
                f"(registered: {sorted(self._publishers) or 'none'})"
            )
        pub.publish(msg)

    def batch(self) -> PublishBatch:
        """A context manager: what this thread publishes inside it leaves at its end, as
        one batch (one lock, at most one wake-up of the writer thread; a small batch with
        nothing queued before it is written at once from this thread, without blocking).
        A simulation wraps each step's callbacks in it. Re-entrant; order is kept."""
        return self._batch

    def subscribe(
        self,
        topic: str,
        msg_type: str,
        callback: MessageCallback,
        raw: bool = False,
        queue_size: int | None = None,
    ) -> Subscription:
        """Call `callback` (on a connector worker, one callback at a time) with every
        message on `topic`.

        `raw=True` passes the payload bytes instead of a decoded message (then `msg_type`
        may be a type the registry does not know; otherwise that raises ConnectorError).
        Several callbacks may share a topic if they agree on its type.
        """
        _check_name(topic, "topic")
        _check_name(msg_type, "message type")
        if not raw:
            self._codec.check_type(msg_type, f"subscriber {topic}")
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
                self._send_command(self._subscribe_command(topic, msg_type, bound))
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

    def set_param(self, name: str, value: Any) -> None:
        """Set the ROS parameter `name` (e.g. `/robot_description`) through the endpoint's
        `set_param` extension, now and again after every reconnection (a restarted
        endpoint or master has forgotten it). An endpoint without the extension (the
        original one) is never sent it: a warning is logged instead. Failures the endpoint
        reports are logged as its `__error`s."""
        _check_name(name, "parameter")
        if value is None:
            raise ConnectorError(f"parameter {name!r}: ROS parameters cannot be None")
        try:
            size = len(json.dumps(value))
        except (TypeError, ValueError) as exc:
            raise ConnectorError(f"parameter {name!r}: value is not JSON ({exc})") from None
        if size > MAX_COMMAND_SIZE - 1024:
            raise ConnectorError(
                f"parameter {name!r}: {size:,} bytes of JSON; a system command holds at most "
                f"{MAX_COMMAND_SIZE - 1024:,}"
            )
        with self._lock:
            self._params[name] = value
            if self._link is None:
                return  # set when the connection is made
            if "set_param" in self._extensions:
                self._send_command(SetParam(name, value))
                return
        _log.warning(
            "the endpoint at %s:%d does not offer the set_param extension (the original "
            "ROS-TCP endpoint has none); parameter %s not set",
            self.host,
            self.port,
            name,
        )

    def endpoint_stats(self, timeout: float | None = None) -> dict[str, Any]:
        """The endpoint's counters for this connection (simbridge `__stats` extension).

        Refused unless the endpoint announced the extension: the original endpoint's
        connection thread dies on system commands it does not know.
        """
        stats: dict[str, Any] = self._ask(
            StatsRequest(), self._stats_waiters, timeout, extension="stats"
        )
        return stats

    def _ask(
        self,
        command: Command,
        waiters: deque[Future[Any]],
        timeout: float | None,
        extension: str | None = None,
    ) -> Any:
        """Send a request whose reply carries no id; replies pair up in order."""
        limit = self.options.request_timeout if timeout is None else timeout
        deadline = time.monotonic() + limit
        if not self.wait_connected(limit):
            raise ConnectorError(f"{command.NAME}: not connected to {self.host}:{self.port}")
        if extension is not None and extension not in self._extensions:
            raise ConnectorError(
                f"the endpoint at {self.host}:{self.port} does not offer {command.NAME} "
                f"(announced extensions: {sorted(self._extensions) or 'none'})"
            )
        future: Future[Any] = Future()
        with self._lock:
            if self._link is None:
                raise ConnectorError(f"{command.NAME}: connection lost")
            waiters.append(future)
            self._out.put_control(self._framer.command(command))
        self._dispatcher.yield_io()  # from a callback: the other worker reads the reply
        try:
            return future.result(max(0.0, deadline - time.monotonic()))
        except FutureTimeoutError:
            future.cancel()
            raise ConnectorError(f"{command.NAME}: no reply within {limit} s") from None

    # ----------------------------------------------------------------- services

    def register_ros_service(self, service: str, srv_type: str, raw: bool = False) -> None:
        """Declare that this connector calls the ROS service `service` of type `srv_type`
        (ConnectorError if the registry does not know it, unless `raw`: only calls with
        request bytes, `call_service(..., raw=True)`, will be made)."""
        _check_name(service, "service")
        _check_name(srv_type, "service type")
        if not raw:
            self._codec.check_type(srv_type, f"service {service}", service=True)
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
        future = self.call_service(service, request, limit)
        if not future.done():
            self._dispatcher.yield_io()  # from a callback: the other worker reads the answer
        try:
            return future.result(limit + 5.0)
        except FutureTimeoutError:
            raise ServiceError(f"{service} did not answer within {limit} s") from None

    async def call_async(self, service: str, request: object, timeout: float | None = None) -> Any:
        """Call a ROS service from asyncio code."""
        return await asyncio.wrap_future(self.call_service(service, request, timeout))

    def implement_service(
        self, service: str, srv_type: str, handler: ServiceHandler, raw: bool = False
    ) -> None:
        """Serve `service` to ROS: `handler(request) -> response` runs on a connector worker
        (one callback or handler at a time).

        With `raw=True` the handler gets the request bytes; it may return bytes or a message
        (and `srv_type` may be a type the registry does not know; otherwise ConnectorError).
        """
        _check_name(service, "service")
        _check_name(srv_type, "service type")
        if not raw:
            self._codec.check_type(srv_type, f"service {service}", service=True)
        with self._lock:
            self._unity_services[service] = ServiceImpl(service, srv_type, handler, raw)
            self._send_command(UnityService(service, srv_type))

    def unimplement_service(self, service: str) -> None:
        """Stop serving `service`."""
        with self._lock:
            if self._unity_services.pop(service, None) is not None:
                self._send_command(RemoveUnityService(service))

    # ---- served ROS 2 actions (the `action_servers` extension) ---------------------------

    def serve_action(self, action: str, handler: ServedHandler) -> None:
        """Serve ROS 2 action `action` through the endpoint, now and after every reconnection;
        its goal and cancel requests go to `handler` as callbacks (`Ros2ActionServer`)."""
        _check_name(action, "action")
        self._served.add(action, handler)
        with self._lock:
            if self._link is not None and ACTION_SERVERS_EXTENSION in self._extensions:
                self._out.put_control(
                    self._framer.command(ServeAction(action, handler.action_type))
                )

    def unserve_action(self, action: str, handler: ServedHandler) -> None:
        """Stop serving `action` (if `handler` serves it); the endpoint aborts its goals."""
        if self._served.remove(action, handler):
            self.send_served(UnserveAction(action))

    def send_served(self, command: Command) -> None:
        """Send one of a served action's commands (answer, feedback, result); dropped while
        not connected, as the endpoint aborted that connection's goals."""
        self._send_served(command)
