"""The ROS 1 backend: the endpoint joins a real ROS 1 master as a rospy node.

rospy registers the node, its topics and services with the master and serves its
slave API, parameters and /rosout. Topic data moves, by default, over the endpoint's
own TCPROS connections on its event loop (`native`: no rospy thread and no
thread hand-off per message); with `Ros1Options(transport="rospy")` it crosses rospy
as raw bytes instead (see `raw`), each callback hopping back to the loop with
`call_soon_threadsafe`. Nothing is decoded either way. Sim-implemented services run
their async handler on the loop while a rospy service thread waits for the answer.
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any, Literal

import rosgraph
import rosgraph.names
import rospy

from simbridge.endpoint.backends.base import (
    Backend,
    BackendPublisher,
    BackendServiceServer,
    BackendSubscription,
    MessageCallback,
    ServiceHandler,
    TopicInfo,
)
from simbridge.endpoint.backends.ros1.msg_types import Ros1Types
from simbridge.endpoint.backends.ros1.native import NativeData
from simbridge.endpoint.backends.ros1.node import NodeIdentity, join_graph, on_node_shutdown
from simbridge.endpoint.backends.ros1.raw import (
    RawMessage,
    RawService,
    raw_message_class,
    raw_service_class,
)
from simbridge.endpoint.backends.ros1.registration import Registration, Ros1Publisher
from simbridge.endpoint.backends.ros1.rejoin import remember_param
from simbridge.endpoint.backends.ros1.rosout import RosoutForwarder
from simbridge.endpoint.backends.subscriber_watch import SubscriberWatch
from simbridge.endpoint.speed.gc_tuning import freeze_startup_objects
from simbridge.endpoint.speed.malloc_tuning import keep_large_buffers
from simbridge.errors import EndpointError, MessageError, ServiceError
from simbridge.messages import MessageRegistry, default_registry

__all__ = ["Ros1Backend", "Ros1Options", "Ros1Publisher"]

_log = logging.getLogger(__name__)


@dataclass(frozen=True, slots=True)
class Ros1Options:
    """How the endpoint joins the ROS 1 graph.

    `ros_args` are ROS command-line arguments (`__name:=x`, `__master:=uri`,
    `_tcp_port:=10000`), e.g. `ros_args(sys.argv)` under roslaunch. `transport`
    picks the topic data path: "native" (the endpoint's own TCPROS on its event loop)
    or "rospy" (rospy's threads). `max_message_size` bounds one received message.
    """

    node_name: str = "simbridge_endpoint"
    ros_args: tuple[str, ...] = ()
    connect_timeout: float = 5.0
    service_handler_timeout: float = 30.0
    forward_logs: bool = True
    service_threads: int = 16
    transport: Literal["native", "rospy"] = "native"
    max_message_size: int = 1 << 30


class Ros1Backend(Backend):
    """Bridges the endpoint's clients into a ROS 1 graph through rospy.

    Types come from `registry` (default: the shared one), so packages loaded into
    it (`--msg-path`) work without catkin or any Python message module.
    """

    name = "ros1"
    protocol = "ROS1"

    def __init__(
        self, options: Ros1Options | None = None, registry: MessageRegistry | None = None
    ) -> None:
        self._options = options or Ros1Options()
        self._types = Ros1Types(registry or default_registry())
        self._loop: asyncio.AbstractEventLoop | None = None
        self._executor: ThreadPoolExecutor | None = None
        self._identity: NodeIdentity | None = None
        self._forwarder: RosoutForwarder | None = None
        self._live: set[Registration] = set()
        self._native: NativeData | None = None
        self._lost_watchers: list[Callable[[str], None]] = []
        self.lends_large_payloads = self._options.transport == "native"
        """The native path sends a large payload from the buffer it was received into."""
        self.splices_large_payloads = self.lends_large_payloads
        """The native path may splice one to a topic's only subscriber (`endpoint.speed.splice`)."""

    @property
    def identity(self) -> NodeIdentity:
        """The node this backend speaks as (after start())."""
        if self._identity is None:
            raise EndpointError("the ROS 1 backend is not started")
        return self._identity

    async def start(self) -> None:
        """Join the master (in a worker thread: rospy blocks until registered).

        Starting again while started does nothing, so a caller may start the backend
        early (say, to read `read_drop_in_params()`) and hand it to the server after.
        """
        if self._loop is not None:
            return
        opts = self._options
        self._identity = await asyncio.to_thread(
            join_graph, opts.node_name, opts.ros_args, opts.connect_timeout
        )
        self._loop = asyncio.get_running_loop()
        self._executor = ThreadPoolExecutor(
            max_workers=opts.service_threads, thread_name_prefix="simbridge-ros1-call"
        )
        if opts.transport == "native":
            keep_large_buffers()  # images: reuse heap buffers, no page faults per copy
            native = NativeData(opts.max_message_size)
            await native.start()
            self._native = native
        on_node_shutdown(self._node_shut_down)
        if opts.forward_logs:
            self._forwarder = RosoutForwarder()
            logging.getLogger("simbridge").addHandler(self._forwarder)
        freeze_startup_objects()  # rospy's, the message types' and the node's objects
        _log.info("joined ROS master %s as %s", self._identity.master_uri, rospy.get_name())

    async def close(self) -> None:
        """Unregister every publisher, subscription and service this backend made."""
        for registration in list(self._live):
            registration.close()
        if self._native is not None:
            self._native.close()
            self._native = None
        if self._executor is not None:
            self._executor.shutdown(wait=False, cancel_futures=True)
            self._executor = None
        if self._forwarder is not None:
            logging.getLogger("simbridge").removeHandler(self._forwarder)
            self._forwarder = None
        self._loop = None

    def stats(self) -> dict[str, int]:
        """The native data path's counters (drops towards slow ROS subscribers and
        refused or failed TCPROS connections); none with the rospy transport."""
        return self._native.stats() if self._native is not None else {}

    def watch_lost(self, callback: Callable[[str], None]) -> None:
        """Call `callback(reason)` on the event loop when the node is shut down for good.

        The master shuts a node down when another registers with the same name; rospy
        cannot join again in the same process, so the endpoint must stop.
        """
        self._lost_watchers.append(callback)

    def _node_shut_down(self, reason: str) -> None:
        """rospy's pre-shutdown hook (a rospy thread); ignored once this backend is closed."""
        loop = self._loop
        if loop is None or not self._lost_watchers:
            return
        text = f"the ROS node {rospy.get_name()} was shut down ({reason})"
        for callback in list(self._lost_watchers):
            try:
                loop.call_soon_threadsafe(callback, text)
            except RuntimeError:  # the loop is closed: the process is exiting anyway
                return

    def advertise(
        self, topic: str, msg_type: str, *, queue_size: int, latch: bool
    ) -> BackendPublisher:
        """Advertise `topic`; publishing never blocks (rospy queues per subscriber)."""
        loop = self._started()
        _check_name(topic, "topic")
        cls = self._topic_class(topic, msg_type)
        try:
            publisher: Ros1Publisher
            if self._native is not None:
                publisher = self._native.advertise(topic, cls, queue_size, latch, self._live)
            else:
                publisher = _RospyPublisher(
                    topic, cls, max(queue_size, 0), latch, loop, live=self._live
                )
        except (rospy.ROSException, ValueError) as exc:
            raise EndpointError(f"cannot advertise {topic!r} as {msg_type}: {exc}") from exc
        _log.info("publishing %s [%s] for the sim (latch=%s)", topic, msg_type, latch)
        return publisher

    def subscribe(
        self, topic: str, msg_type: str, callback: MessageCallback
    ) -> BackendSubscription:
        """Subscribe with the type's real md5sum; payloads arrive on the event loop."""
        loop = self._started()
        _check_name(topic, "topic")
        cls = self._topic_class(topic, msg_type)
        try:
            subscription: BackendSubscription
            if self._native is not None:
                subscription = self._native.subscribe(topic, cls, callback, self._live)
            else:
                subscription = _Ros1Subscription(topic, cls, loop, callback, self._live)
        except (rospy.ROSException, ValueError) as exc:
            raise EndpointError(f"cannot subscribe to {topic!r} as {msg_type}: {exc}") from exc
        _log.info("subscribed to %s [%s] for the sim", topic, msg_type)
        return subscription

    async def call_service(
        self, service: str, srv_type: str, request: bytes, *, timeout: float
    ) -> bytes:
        """Call a ROS service in a worker thread; missing, failed or slow -> ServiceError."""
        loop = self._started()
        try:
            _check_name(service, "service")
            cls = raw_service_class(self._types.service(srv_type))
        except (MessageError, EndpointError) as exc:
            raise ServiceError(f"cannot call {service!r}: {exc}") from exc
        proxy = rospy.ServiceProxy(service, cls, persistent=True)
        call = loop.run_in_executor(self._executor, proxy.call, cls._request_class(request))
        try:
            response: RawMessage = await asyncio.wait_for(call, timeout)
        except TimeoutError as exc:
            raise ServiceError(f"service {service!r} did not answer within {timeout} s") from exc
        except (rospy.ServiceException, rospy.ROSException, OSError) as exc:
            raise ServiceError(f"service {service!r} failed: {exc}") from exc
        finally:
            proxy.close()  # also unblocks a worker still waiting after a timeout
        return response.payload

    def advertise_service(
        self, service: str, srv_type: str, handler: ServiceHandler
    ) -> BackendServiceServer:
        """Offer `service` to ROS; each call runs `handler` on the event loop."""
        loop = self._started()
        _check_name(service, "service")
        cls = raw_service_class(self._types.service(srv_type))
        timeout = self._options.service_handler_timeout
        try:
            server = _Ros1ServiceServer(service, cls, loop, handler, timeout, live=self._live)
        except (rospy.ROSException, ValueError) as exc:
            raise EndpointError(f"cannot advertise service {service!r}: {exc}") from exc
        _log.info("serving %s [%s] for the sim", service, srv_type)
        return server

    async def set_param(self, name: str, value: Any) -> None:
        """`rospy.set_param` on the master's parameter server (in a worker thread: it is an
        XML-RPC call). A restarted master gets it again with the node's registrations."""
        loop = self._started()
        _check_name(name, "parameter")
        try:
            await loop.run_in_executor(self._executor, rospy.set_param, name, value)
        except Exception as exc:  # XML-RPC faults, OverflowError (ints past 32 bits), OSError
            raise EndpointError(f"cannot set parameter {name!r}: {exc}") from exc
        resolved = rospy.resolve_name(name)
        if not remember_param(resolved, value):
            _log.warning("%s is set but would not be set again on a restarted master", resolved)
        _log.info("set parameter %s for the sim", resolved)

    def topics(self) -> list[TopicInfo]:
        """The topics that have a publisher or a subscriber now, with their types, by name.

        Like `rostopic list`: the master's getTopicTypes alone also remembers every topic
        of nodes long gone, so the live ones come from getSystemState.
        """
        self._started()
        try:
            master = rosgraph.Master(rospy.get_name(), master_uri=self.identity.master_uri)
            publishers, subscribers, _ = master.getSystemState()
            types = dict(master.getTopicTypes())
        except (rosgraph.MasterException, OSError) as exc:
            raise EndpointError(f"cannot list topics from the ROS master: {exc}") from exc
        live = {name for name, nodes in (*publishers, *subscribers) if nodes}
        return [TopicInfo(name, types.get(name, "*")) for name in sorted(live)]

    def _topic_class(self, topic: str, msg_type: str) -> type[RawMessage]:
        """The raw class of `msg_type`, refusing a topic this node already uses with
        another type (rospy would silently share one connection for both)."""
        cls = raw_message_class(self._types.message(msg_type))
        resolved = rospy.resolve_name(topic)
        for other in self._live:
            if other.topic == resolved and other.msg_type != cls._type:
                raise EndpointError(
                    f"{resolved} is already used as {other.msg_type} by this endpoint; "
                    f"it cannot also be {cls._type} (one type per topic)"
                )
        return cls

    def _started(self) -> asyncio.AbstractEventLoop:
        if self._loop is None:
            raise EndpointError("the ROS 1 backend is not started: await start() first")
        return self._loop


def _check_name(name: str, what: str) -> None:
    """Refuse what the master would reject later (rospy itself only warns)."""
    if not name or not rosgraph.names.is_legal_name(name):
        raise EndpointError(
            f"{what} name {name!r} is not a legal ROS name: letters, digits, '_' and '/', "
            f"starting with a letter, '/' or '~'"
        )


class _PeerListener(rospy.SubscribeListener):  # type: ignore[misc]
    """Tells a publisher, from rospy's threads, that a subscriber connected or left."""

    def __init__(self, changed: Callable[[], None]) -> None:
        self._changed = changed

    def peer_subscribe(self, topic_name: str, topic_publish: Any, peer_publish: Any) -> None:
        self._changed()

    def peer_unsubscribe(self, topic_name: str, num_peers: int) -> None:
        self._changed()


class _RospyPublisher(Ros1Publisher):
    """A rospy Publisher of raw bytes."""

    def __init__(
        self,
        topic: str,
        cls: type[RawMessage],
        queue_size: int,
        latch: bool,
        loop: asyncio.AbstractEventLoop,
        *,
        live: set[Registration],
    ) -> None:
        self._cls = cls
        self._subscribers = SubscriberWatch(loop, self.subscriber_count, lambda: self.closed)
        self._publisher = rospy.Publisher(
            topic,
            cls,
            queue_size=queue_size,
            latch=latch,
            subscriber_listener=_PeerListener(self._subscribers.changed),
        )
        self.topic: str = self._publisher.resolved_name
        self.msg_type = cls._type
        super().__init__(live)

    def publish(self, payload: bytes | bytearray) -> None:
        if self.closed:
            raise EndpointError(f"publisher of {self.topic!r} is closed")
        try:
            self._publisher.publish(self._cls(bytes(payload)))
        except rospy.ROSException as exc:
            raise EndpointError(f"cannot publish on {self.topic!r}: {exc}") from exc

    def subscriber_count(self) -> int:
        """How many subscribers are connected now (messages before the first one are lost)."""
        count: int = self._publisher.get_num_connections()
        return count

    def watch_subscribers(self, callback: Callable[[int], None]) -> bool:
        """Call `callback(count)` now and on the event loop whenever the count changes.

        A subscriber that leaves is noticed when rospy next writes to it (TCPROS has
        no goodbye), so the drop to zero shows up at the next publish.
        """
        return self._subscribers.add(callback)

    def _unregister(self) -> None:
        self._publisher.unregister()
        _log.info("stopped publishing %s", self.topic)


class _Ros1Subscription(Registration, BackendSubscription):
    """A rospy Subscriber whose raw payloads are delivered on the event loop."""

    def __init__(
        self,
        topic: str,
        cls: type[RawMessage],
        loop: asyncio.AbstractEventLoop,
        callback: MessageCallback,
        live: set[Registration],
    ) -> None:
        self._loop = loop
        self._callback = callback
        self._subscriber = rospy.Subscriber(topic, cls, self._on_message)
        self.topic: str = self._subscriber.resolved_name
        self.msg_type = cls._type
        super().__init__(live)

    def _on_message(self, message: RawMessage) -> None:
        """Runs on a rospy receive thread."""
        try:
            self._loop.call_soon_threadsafe(self._deliver, message.payload)
        except RuntimeError:  # the loop is closed: the endpoint is going away
            return

    def _deliver(self, payload: bytes) -> None:
        if not self.closed:
            self._callback(payload)

    def _unregister(self) -> None:
        self._subscriber.unregister()
        _log.info("unsubscribed from %s", self.topic)


class _Ros1ServiceServer(Registration, BackendServiceServer):
    """A rospy Service whose implementation is an async handler on the event loop."""

    def __init__(
        self,
        service: str,
        cls: type[RawService],
        loop: asyncio.AbstractEventLoop,
        handler: ServiceHandler,
        timeout: float,
        *,
        live: set[Registration],
    ) -> None:
        self._service = service
        self._response_class = cls._response_class
        self._loop = loop
        self._handler = handler
        self._timeout = timeout
        self._server = rospy.Service(service, cls, self._on_request)
        super().__init__(live)

    async def _run(self, request: bytes) -> bytes:
        return await self._handler(request)

    def _on_request(self, request: RawMessage) -> RawMessage:
        """Runs on a rospy service thread; any exception becomes the caller's error."""
        if self.closed or self._loop.is_closed():
            raise rospy.ServiceException(f"service {self._service} is being removed")
        future = asyncio.run_coroutine_threadsafe(self._run(request.payload), self._loop)
        try:
            response = future.result(self._timeout)
        except TimeoutError as exc:
            future.cancel()
            raise rospy.ServiceException(
                f"the sim did not answer {self._service} within {self._timeout} s"
            ) from exc
        except Exception as exc:
            raise rospy.ServiceException(f"the sim failed {self._service}: {exc}") from exc
        return self._response_class(response)

    def _unregister(self) -> None:
        self._server.shutdown("removed by the endpoint")
        _log.info("stopped serving %s", self._service)
