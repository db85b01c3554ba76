"""The ROS 2 backend: the endpoint is a real rclpy node (`/simbridge_endpoint`).

Topics are relayed as raw CDR in both directions: `publisher.publish(bytes)` (a large
payload in place through rcl, `rcl`) and `create_subscription(..., raw=True)`,
nothing decoded on the hot path. Services
have no raw mode in rclpy, so their requests and responses are decoded and
encoded with the installed interface classes (in `calls`, one rclpy client per
`__ros_service`); so are action goals, feedback and results (the `actions` extension, in
`actions`). A type without fields is the one payload rewritten on its way: a client
may send the CDR header alone (Unity does), which rclpy refuses, so ROS 2 gets rclpy's
spelling and clients the header alone (`cdr`, `simbridge.messages.empty`).

rclpy runs one SingleThreadedExecutor on a thread of its own for services, clients
and actions. Publishers, subscriptions and clients are created from the endpoint's
event loop (rclpy allows that with this executor; its EventsExecutor does not, and
it cannot run the coroutine service callbacks a sim-implemented service needs).
Subscribed messages are taken on the event loop itself, woken by a thread that only
waits (`takes`). The process's ROS 2 settings (domain, discovery range, the Fast
DDS profile) come from `env` and are logged; large buffers stay in the heap
(`speed.malloc_tuning`), and the objects made at startup are left out of garbage collections
(`speed.gc_tuning`).
"""

from __future__ import annotations

import asyncio
import logging
import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import rclpy
import rclpy.executors
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import serialize_message

from simbridge.endpoint.backends.base import (
    Backend,
    BackendActionGoal,
    BackendPublisher,
    BackendServiceClient,
    BackendServiceServer,
    BackendSubscription,
    MessageCallback,
    ServiceHandler,
    TopicInfo,
)
from simbridge.endpoint.backends.ros2.actions import Ros2Actions
from simbridge.endpoint.backends.ros2.calls import Ros2ServiceClient
from simbridge.endpoint.backends.ros2.entities import (
    NodeEntity,
    Ros2Publisher,
    Ros2ServiceServer,
    Ros2Subscription,
    SimServiceFailedError,
)
from simbridge.endpoint.backends.ros2.env import apply_ros2_env
from simbridge.endpoint.backends.ros2.lossless import LosslessRos2Publisher
from simbridge.endpoint.backends.ros2.msg_types import Ros2Types, tcp_type_name
from simbridge.endpoint.backends.ros2.served import Ros2ServedActions
from simbridge.endpoint.backends.ros2.takes import LoopTakes
from simbridge.endpoint.backends.served import BackendActionServer, ServedGoalSink
from simbridge.endpoint.speed.gc_tuning import freeze_startup_objects
from simbridge.endpoint.speed.malloc_tuning import keep_large_buffers
from simbridge.endpoint.typecheck import TypeCheck
from simbridge.errors import EndpointError, ServiceError
from simbridge.protocol import ACTION_SERVERS_EXTENSION, ACTIONS_EXTENSION

__all__ = ["Ros2Backend", "Ros2Options", "Ros2TypeCheck", "ros2_cli_args"]

_log = logging.getLogger(__name__)


@dataclass(frozen=True, slots=True)
class Ros2Options:
    """How the endpoint joins the ROS 2 graph.

    `ros_args` are rcl arguments as after `--ros-args` (`-r __node:=x`, `-r /a:=/b`,
    `-p name:=value`). `domain_id` replaces ROS_DOMAIN_ID when given.
    """

    node_name: str = "simbridge_endpoint"
    ros_args: tuple[str, ...] = ()
    domain_id: int | None = None
    discovery_wait: float = 5.0
    """How long a service call waits for a server to be discovered before failing."""
    service_handler_timeout: float = 30.0
    """How long a ROS 2 caller's request waits for the sim's answer."""


def ros2_cli_args(args: tuple[str, ...]) -> tuple[str, ...]:
    """ROS arguments from the command line as rcl `--ros-args` items.

    Items after a `--ros-args` marker are rcl syntax already and kept as they are.
    Before it, ROS 1 style ones (as roslaunch passes them) are translated:
    `__name:=x` -> `-r __node:=x`, `_param:=v` -> `-p param:=v`, `from:=to` -> `-r from:=to`.
    """
    out: list[str] = []
    rcl = False
    for arg in args:
        if arg == "--ros-args":
            rcl = True
        elif arg == "--":
            rcl = False
        elif rcl or ":=" not in arg:
            out.append(arg)
        else:
            key, value = arg.split(":=", 1)
            if key == "__name":
                out += ["-r", f"__node:={value}"]
            elif key.startswith("_") and not key.startswith("__"):
                out += ["-p", f"{key[1:]}:={value}"]
            else:
                out += ["-r", arg]
    return tuple(out)


class Ros2TypeCheck(TypeCheck):
    """Accepts every type with an installed ROS 2 interface; names come back as `pkg/Type`."""

    def __init__(self, types: Ros2Types) -> None:
        self._types = types

    def message(self, name: str) -> str:
        cls = self._types.message(name)
        return f"{cls.__module__.split('.')[0]}/{cls.__name__}"

    def service(self, name: str) -> str:
        cls = self._types.service(name)
        return f"{cls.__module__.split('.')[0]}/{cls.__name__}"


class Ros2Backend(Backend):
    """Bridges the endpoint's clients into a ROS 2 graph through rclpy."""

    name = "ros2"
    lends_large_payloads = True  # published in place (`rcl`)
    releases_lent_payloads = True  # rcl copies it into Fast DDS before returning
    protocol = "ROS2"
    extensions = (ACTIONS_EXTENSION, ACTION_SERVERS_EXTENSION)

    def __init__(self, options: Ros2Options | None = None) -> None:
        self._options = options or Ros2Options()
        self._types = Ros2Types()
        self._loop: asyncio.AbstractEventLoop | None = None
        self._context: Any = None
        self._node: Any = None
        self._executor: Any = None
        self._thread: threading.Thread | None = None
        self._callers: set[Ros2ServiceClient] = set()
        """Service clients (`service_client`), destroyed by close() if still open."""
        self._descriptions: dict[str, Ros2Publisher] = {}
        """`__set_param` of `*/robot_description`: its latched topic's publisher."""
        self._live: set[NodeEntity] = set()
        self._takes: LoopTakes | None = None
        self.settings: dict[str, str] = {}
        self.counters: dict[str, int] = {
            "publish_errors": 0,
            "service_failures": 0,
            "lossless_pushbacks": 0,
            "lossless_dropped": 0,
        }
        self._actions = Ros2Actions(self, self._types)
        self._served = Ros2ServedActions(self, self._types, self.counters)

    def type_check(self) -> TypeCheck:
        return Ros2TypeCheck(self._types)

    @property
    def node(self) -> Any:
        """The rclpy node (after start())."""
        if self._node is None:
            raise EndpointError("the ROS 2 backend is not started: await start() first")
        return self._node

    async def start(self) -> None:
        """Set the ROS 2 environment, create the node and spin it on a thread."""
        if self._loop is not None:
            return
        opts = self._options
        self.settings = apply_ros2_env(domain_id=opts.domain_id)
        keep_large_buffers()  # images: reuse heap buffers, no page faults per copy
        context = rclpy.Context()
        args = ["simbridge", "--ros-args", *opts.ros_args] if opts.ros_args else None
        try:
            rclpy.init(args=args, context=context)
            node = rclpy.create_node(opts.node_name.lstrip("/"), context=context)
        except Exception as exc:
            raise EndpointError(f"cannot start the ROS 2 node: {exc}") from exc
        executor = rclpy.executors.SingleThreadedExecutor(context=context)
        executor.add_node(node)
        self._context, self._node, self._executor = context, node, executor
        self._loop = asyncio.get_running_loop()
        freeze_startup_objects()  # rclpy's and the node's objects: out of every collection
        self._takes = LoopTakes(context, self._loop)
        self._thread = threading.Thread(target=self._spin, name="simbridge-rclpy", daemon=True)
        self._thread.start()
        _log.info(
            "joined ROS 2 as %s (%s)",
            node.get_fully_qualified_name(),
            ", ".join(f"{k}={v}" for k, v in self.settings.items()),
        )

    def _spin(self) -> None:
        """Runs on the rclpy thread until close(); a failed callback is logged, not fatal."""
        while self._context is not None and self._context.ok():
            try:
                self._executor.spin_once(timeout_sec=0.5)
            except SimServiceFailedError as exc:
                self.counters["service_failures"] += 1
                _log.error("%s", exc)
            except rclpy.executors.ExternalShutdownException:
                return
            except Exception:
                if self._context is None or not self._context.ok():
                    return
                _log.exception("rclpy callback failed")

    async def close(self) -> None:
        """Destroy every entity, leave the graph and stop the rclpy thread."""
        if self._loop is None:
            return
        for entity in list(self._live):
            entity.close()
        for caller in list(self._callers):
            caller.close()
        await self._served.close()
        await self._actions.close()
        if self._takes is not None:
            await self._takes.close()
            self._takes = None
        context = self._context
        with_thread = self._thread
        try:
            rclpy.shutdown(context=context)
        except Exception as exc:  # already shut down (e.g. by a signal)
            _log.debug("rclpy shutdown: %s", exc)
        if with_thread is not None:
            await asyncio.to_thread(with_thread.join, 5.0)
        self._executor.shutdown(timeout_sec=1.0)
        self._node.destroy_node()
        self._loop = None
        self._context = None
        _log.info("left ROS 2")

    def stats(self) -> dict[str, int]:
        return dict(self.counters)

    # ---- topics ----------------------------------------------------------------------

    def advertise(
        self, topic: str, msg_type: str, *, queue_size: int, latch: bool
    ) -> BackendPublisher:
        """A reliable publisher; `latch` is transient-local durability. DDS keeps the last
        `queue_size` samples for a subscriber that has not acknowledged them (a faster
        publisher overwrites the oldest, which the endpoint cannot see); queue_size 0 keeps
        all, and the client is pushed back on instead (`lossless`)."""
        loop = self.running_loop()
        cls = self._types.message(msg_type)
        qos = QoSProfile(
            history=HistoryPolicy.KEEP_ALL if queue_size == 0 else HistoryPolicy.KEEP_LAST,
            depth=max(queue_size, 1),
            reliability=ReliabilityPolicy.RELIABLE,
            durability=DurabilityPolicy.TRANSIENT_LOCAL if latch else DurabilityPolicy.VOLATILE,
        )
        kind = LosslessRos2Publisher if queue_size == 0 else Ros2Publisher
        publisher = kind(self, topic, cls, qos, loop, live=self._live)
        _log.info("publishing %s [%s] for the sim (latch=%s)", topic, msg_type, latch)
        return publisher

    def subscribe(
        self, topic: str, msg_type: str, callback: MessageCallback
    ) -> BackendSubscription:
        """A raw subscription whose QoS matches the topic's publishers."""
        self.running_loop()
        cls = self._types.message(msg_type)
        assert self._takes is not None
        subscription = Ros2Subscription(
            self,
            topic,
            cls,
            self._adapted_qos(topic),
            takes=self._takes,
            callback=callback,
            live=self._live,
        )
        _log.info("subscribed to %s [%s] for the sim", topic, msg_type)
        return subscription

    async def set_param(self, name: str, value: Any) -> None:
        """ROS 2 has no parameter server. By its convention (robot_state_publisher's) a
        robot description is a transient-local std_msgs/String topic, so
        `<ns>/robot_description` is published there; other parameters are refused."""
        loop = self.running_loop()
        if name.rstrip("/").rsplit("/", 1)[-1] != "robot_description":
            raise EndpointError(
                f"cannot set parameter {name!r}: ROS 2 has no global parameter server (node "
                "parameters belong to their nodes); the ros2 backend publishes only "
                "*/robot_description, as a transient-local std_msgs/String topic"
            )
        if not isinstance(value, str):
            kind = type(value).__name__
            raise EndpointError(f"{name!r} must be a string (URDF text), got {kind}")
        publisher = self._descriptions.get(name)
        if publisher is None or publisher.closed:
            cls = self._types.message("std_msgs/String")
            qos = QoSProfile(
                history=HistoryPolicy.KEEP_LAST,
                depth=1,
                reliability=ReliabilityPolicy.RELIABLE,
                durability=DurabilityPolicy.TRANSIENT_LOCAL,
            )
            publisher = self._descriptions[name] = Ros2Publisher(
                self, name, cls, qos, loop, live=self._live
            )
        publisher.publish(serialize_message(publisher.msg_class(data=value)))
        _log.info("published %s (std_msgs/String, transient local) for the sim", publisher.topic)

    def _adapted_qos(self, topic: str) -> QoSProfile:
        """Reliable unless a publisher is best effort; transient local if all publishers are
        (so a latched message reaches the sim, and no publisher is left unmatched)."""
        try:
            infos = self.node.get_publishers_info_by_topic(self.node.resolve_topic_name(topic))
        except Exception:
            infos = []
        reliable = all(i.qos_profile.reliability != ReliabilityPolicy.BEST_EFFORT for i in infos)
        latched = bool(infos) and all(
            i.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL for i in infos
        )
        # A reliable subscription keeps all: when the rclpy thread falls behind a burst, DDS
        # flow control slows the publisher instead of overwriting samples. The sim side's
        # bound is the client's queue_size (its outbox), where drops are counted.
        return QoSProfile(
            history=HistoryPolicy.KEEP_ALL if reliable else HistoryPolicy.KEEP_LAST,
            depth=100,
            reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
            durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE,
        )

    def topics(self) -> list[TopicInfo]:
        """Every topic in the graph, types as `pkg/Type` (the first when there are several)."""
        self.running_loop()
        pairs = self.node.get_topic_names_and_types()
        return [TopicInfo(name, tcp_type_name(types[0])) for name, types in sorted(pairs) if types]

    # ---- services --------------------------------------------------------------------

    def service_client(self, service: str, srv_type: str) -> BackendServiceClient:
        """An rclpy client of `service` for one TCP client's calls (`calls`)."""
        loop = self.running_loop()
        cls = self._types.service(srv_type)
        caller = Ros2ServiceClient(
            self.node,
            loop,
            service,
            srv_type,
            cls,
            discovery_wait=self._options.discovery_wait,
            on_close=self._callers.discard,
        )
        self._callers.add(caller)
        _log.info("calling %s [%s] for the sim", service, srv_type)
        return caller

    async def call_service(
        self, service: str, srv_type: str, request: bytes, *, timeout: float
    ) -> bytes:
        """Call a ROS 2 service once, through a client made for the call and destroyed
        after it; no server, a bad request or no answer -> ServiceError."""
        try:
            caller = self.service_client(service, srv_type)
        except EndpointError as exc:
            raise ServiceError(f"cannot call {service!r}: {exc}") from exc
        try:
            return await caller.call(request, timeout=timeout)
        finally:
            caller.close()

    def advertise_service(
        self, service: str, srv_type: str, handler: ServiceHandler
    ) -> BackendServiceServer:
        """Offer `service` to ROS 2; each request runs `handler` on the event loop."""
        loop = self.running_loop()
        cls = self._types.service(srv_type)
        server = Ros2ServiceServer(
            self,
            service,
            cls,
            loop=loop,
            handler=handler,
            timeout=self._options.service_handler_timeout,
            live=self._live,
        )
        _log.info("serving %s [%s] for the sim", service, srv_type)
        return server

    # ---- actions (the `actions` extension) -------------------------------------------

    async def action_server_ready(self, action: str, action_type: str) -> bool:
        self.running_loop()
        return await self._actions.server_ready(action, action_type)

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
        self.running_loop()
        return await self._actions.send_goal(
            action,
            action_type,
            goal,
            on_feedback=on_feedback,
            on_status=on_status,
            timeout=timeout,
            discovery_wait=self._options.discovery_wait,
        )

    def serve_action(
        self, action: str, action_type: str, sink: ServedGoalSink
    ) -> BackendActionServer:
        """Host an rclpy ActionServer for `action`; its goals go to `sink` (the client)."""
        self.running_loop()
        return self._served.serve(
            action, action_type, sink, timeout=self._options.service_handler_timeout
        )

    def running_loop(self) -> asyncio.AbstractEventLoop:
        """The event loop the backend started on (EndpointError before start())."""
        if self._loop is None:
            raise EndpointError("the ROS 2 backend is not started: await start() first")
        return self._loop

    def on_rclpy_thread(self, fn: Callable[[], Any]) -> None:
        """Run `fn` on the rclpy thread, as a task of its executor."""
        self._executor.create_task(fn)

    def wake_rclpy(self) -> None:
        """Wake the rclpy thread (a future one of its tasks awaits was set elsewhere)."""
        self._executor.wake()
