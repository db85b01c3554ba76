"""The interface between the endpoint and a ROS graph (embedded bus, ROS 1, ROS 2).

Payloads cross this boundary as serialized bytes (ROS 1 binary for ROS 1 graphs,
CDR for ROS 2): the endpoint never decodes a message just to route it.
All methods are called on the endpoint's event loop thread, and backends must
invoke the callbacks they are given on that same thread.
"""

from __future__ import annotations

import abc
from collections.abc import Awaitable, Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

from simbridge.errors import EndpointError

if TYPE_CHECKING:
    from simbridge.endpoint.backends.served import BackendActionServer, ServedGoalSink
    from simbridge.endpoint.speed.splice import SpliceSink
    from simbridge.endpoint.typecheck import TypeCheck

__all__ = [
    "Backend",
    "BackendActionGoal",
    "BackendPublisher",
    "BackendServiceClient",
    "BackendServiceServer",
    "BackendSubscription",
    "BatchCallback",
    "LentCallback",
    "MessageCallback",
    "ServiceHandler",
    "TopicInfo",
]

MessageCallback = Callable[[bytes], None]
"""Receives one serialized message; called on the event loop thread."""

BatchCallback = Callable[[Sequence[bytes]], int]
"""Receives serialized messages that arrived together, in order, on the event loop thread;
returns how many it took from the front (the rest are offered again later)."""

LentCallback = Callable[[memoryview], None]
"""Receives one serialized message as a view of the backend's own buffer, lent for the
call only (the backend reuses the memory afterwards: copy what you keep); on the event
loop thread."""

ServiceHandler = Callable[[bytes], Awaitable[bytes]]
"""Turns a serialized request into a serialized response (raise to fail the call)."""


@dataclass(frozen=True, slots=True)
class TopicInfo:
    """A topic in the graph and its message type (`package/Type`)."""

    name: str
    msg_type: str


class BackendPublisher(abc.ABC):
    """An advertised topic; publishes serialized messages as they are."""

    @abc.abstractmethod
    def publish(self, payload: bytes | bytearray) -> None:
        """Send one serialized message to every subscriber of the topic. A bytearray is
        handed over (a large payload as received): nobody writes to it afterwards."""

    @abc.abstractmethod
    def close(self) -> None:
        """Unadvertise; further publishes are an error."""

    def watch_subscribers(self, callback: Callable[[int], None]) -> bool:
        """Call `callback(count)` now and whenever the topic's subscriber count changes.

        Returns False when the backend cannot tell (the default).
        """
        return False

    def splice_sink(self) -> SpliceSink | None:
        """Where the next large message may be spliced straight from the client's socket
        (`endpoint.speed.splice`), or None: it is published as usual (the default)."""
        return None

    def in_flight(self) -> bool:
        """Whether something published may not have reached the subscribers yet (a drain
        would wait); False by default, and then close() follows at once."""
        return False

    async def drain(self, timeout: float) -> int:
        """Wait, at most `timeout` s, until what was published has left for the topic's
        subscribers, so close() loses nothing accepted (a client that publishes and leaves
        at once); returns how many messages may still be undelivered (0: none). The
        default holds nothing after publish() returns: 0."""
        return 0

    def watch_backlog(self, behind: Callable[[], None], caught_up: Callable[[], None]) -> bool:
        """Call `behind()` when a subscriber falls behind on a topic that must not drop
        (queue_size 0), so the caller stops reading from its client, and `caught_up()`
        when none is behind any more. Returns False when the backend never pushes back
        (it holds or drops by queue_size instead; the default)."""
        return False


class BackendSubscription(abc.ABC):
    """A live subscription; close it to stop the callbacks."""

    @abc.abstractmethod
    def close(self) -> None:
        """Stop delivering messages."""

    def throttle(self, blocked: Callable[[], bool]) -> bool:
        """Stop taking messages from the graph while `blocked()` is true, so the graph's
        publisher is pushed back on instead of messages being dropped; `unblocked()`
        says when to ask again. Returns False when the backend cannot (the default)."""
        return False

    def unblocked(self) -> None:  # noqa: B027 - optional hook
        """The consumer caught up after `blocked()` was true."""

    def batches(self, callback: BatchCallback) -> bool:
        """Hand messages that arrive together (one read's worth) to `callback` in one call
        instead of one message callback each, so the consumer handles them at once; returns
        False when the backend cannot (the default)."""
        return False

    def lends(self, callback: LentCallback) -> bool:
        """Hand large messages to `callback` as views lent for the call only instead of
        `bytes` to the message callback, where that saves the backend a copy; returns
        False when the backend cannot (the default)."""
        return False


class BackendServiceServer(abc.ABC):
    """A service advertised in the graph whose implementation is a handler."""

    @abc.abstractmethod
    def close(self) -> None:
        """Unadvertise the service."""


class BackendServiceClient(abc.ABC):
    """A caller of one service in the graph for one TCP client (its `__ros_service`), closed
    when the client removes the registration or leaves, like everything else it made."""

    @abc.abstractmethod
    async def call(self, request: bytes, *, timeout: float) -> bytes:
        """Call the service; raises ServiceError on failure, timeout or close()."""

    @abc.abstractmethod
    def close(self) -> None:
        """Release what it holds in the graph (a call in flight that needs it then fails)."""


class _CallEach(BackendServiceClient):
    """A caller that is no graph entity: each call goes to `Backend.call_service`."""

    def __init__(self, backend: Backend, service: str, srv_type: str) -> None:
        self._backend = backend
        self._service = service
        self._srv_type = srv_type

    async def call(self, request: bytes, *, timeout: float) -> bytes:
        return await self._backend.call_service(
            self._service, self._srv_type, request, timeout=timeout
        )

    def close(self) -> None:
        """Nothing was made."""


class BackendActionGoal(abc.ABC):
    """A goal an action server accepted (ROS 2 actions, the `actions` extension)."""

    @abc.abstractmethod
    async def result(self) -> tuple[int, bytes]:
        """Wait for the end: the terminal action_msgs/GoalStatus and the serialized result."""

    @abc.abstractmethod
    async def cancel(self) -> bool:
        """Ask the server to cancel the goal; True when it agreed."""

    @abc.abstractmethod
    def abandon(self) -> None:
        """The client is gone: cancel the goal without waiting and stop every callback."""


class Backend(abc.ABC):
    """A ROS graph the endpoint bridges its TCP clients into."""

    name: str = "abstract"
    protocol: Literal["ROS1", "ROS2"] = "ROS1"
    """Serialization its payloads use: "ROS1" (binary) or "ROS2" (CDR, ROS 2 layouts)."""
    extensions: tuple[str, ...] = ()
    """Protocol extensions it adds to the handshake's (e.g. "actions")."""
    lends_large_payloads: bool = False
    """Its publishers take a large payload as the bytearray it was received into (the
    client's decoder then allocates one per large frame instead of reusing its buffer);
    worth it only where the publisher would otherwise copy the payload to bytes."""
    splices_large_payloads: bool = False
    """Some of its publishers may take a large payload straight from the client's socket
    (`BackendPublisher.splice_sink`); sessions of other backends never look for one."""
    releases_lent_payloads: bool = False
    """Its publishers are done with a lent payload when publish() returns (they copied
    what they send), so the session gives the buffer back to the client's decoder, which
    receives the next large frame of that size into it (no allocation, no zero-fill)."""

    async def start(self) -> None:  # noqa: B027 - optional hook
        """Connect to the graph; called once on the event loop before any other call."""

    async def close(self) -> None:  # noqa: B027 - optional hook
        """Release every registration and leave the graph."""

    def watch_lost(self, callback: Callable[[str], None]) -> None:  # noqa: B027 - optional hook
        """Call `callback(reason)` on the event loop if the backend leaves the graph for good
        (the ROS 1 master shut its node down, say). The default never calls it."""

    def type_check(self) -> TypeCheck | None:
        """How this graph validates type names, when not by simbridge's registry (None)."""
        return None

    def stats(self) -> dict[str, int]:
        """Backend counters for `__stats` (e.g. failed publishes); none by default."""
        return {}

    async def set_param(self, name: str, value: Any) -> None:
        """Set the graph parameter `name` (`__set_param`); EndpointError where the graph
        has no such parameter (the default)."""
        raise EndpointError(f"the {self.name} backend cannot set parameters ({name!r})")

    @abc.abstractmethod
    def advertise(
        self, topic: str, msg_type: str, *, queue_size: int, latch: bool
    ) -> BackendPublisher:
        """Advertise `topic` with type `msg_type` (`package/Type`)."""

    @abc.abstractmethod
    def subscribe(
        self, topic: str, msg_type: str, callback: MessageCallback
    ) -> BackendSubscription:
        """Call `callback(payload)` for every message published on `topic`."""

    @abc.abstractmethod
    async def call_service(
        self, service: str, srv_type: str, request: bytes, *, timeout: float
    ) -> bytes:
        """Call a service in the graph; raises ServiceError on failure or timeout."""

    def service_client(self, service: str, srv_type: str) -> BackendServiceClient:
        """A caller of `service` for one TCP client, to close when that client is done
        with it. The default holds nothing and goes through `call_service` (for graphs
        where a call leaves nothing behind)."""
        return _CallEach(self, service, srv_type)

    @abc.abstractmethod
    def advertise_service(
        self, service: str, srv_type: str, handler: ServiceHandler
    ) -> BackendServiceServer:
        """Offer a service to the graph, implemented by `handler`."""

    async def action_server_ready(self, action: str, action_type: str) -> bool:
        """Whether a server for `action` is reachable now (backends with "actions")."""
        raise EndpointError(f"the {self.name} backend has no ROS 2 actions (try --backend ros2)")

    async def send_goal(
        self,
        action: str,
        action_type: str,
        goal: bytes,
        *,
        on_feedback: MessageCallback,
        on_status: Callable[[int], None],
        timeout: float,
    ) -> BackendActionGoal:
        """Send a serialized goal to action `action` (`pkg/Action`) and wait until the server
        accepts it (a server found within `timeout`). Status changes go to `on_status` on the
        event loop, STATUS_ACCEPTED first (before any feedback), then feedback to
        `on_feedback`. Raises SimbridgeError when no server answers, the type
        is unknown or the server rejects the goal. Cancelling the waiting coroutine cancels
        the goal once accepted."""
        raise EndpointError(f"the {self.name} backend has no ROS 2 actions (try --backend ros2)")

    def serve_action(
        self, action: str, action_type: str, sink: ServedGoalSink
    ) -> BackendActionServer:
        """Host an action server for `action` (`pkg/Action`) whose goals go to `sink`
        (backends with "action_servers")."""
        raise EndpointError(
            f"the {self.name} backend cannot serve ROS 2 actions ({action!r}; try --backend ros2)"
        )

    @abc.abstractmethod
    def topics(self) -> list[TopicInfo]:
        """Every topic the graph knows, with its type."""
