"""Route the rospy node's topic negotiation for the endpoint's topics to its own TCPROS I/O.

rospy keeps the node's XML-RPC slave API (registration, requestTopic, publisherUpdate,
parameters, services, rosout, master-restart rejoin): only the data path moves. Its
TCPROS protocol handler is wrapped, once per process, by one that answers
`requestTopic` for an endpoint-published topic with the endpoint's own server address,
and turns rospy's `create_transport` for an endpoint-subscribed topic into an asyncio
connection on the endpoint's loop. Every other topic (rospy's own /rosout, say) goes
to rospy's handler unchanged. The master's publisher lists for those topics (the
registration's answer and every publisherUpdate) are passed on too, so a dropped
connection is retried only while its publisher is listed. These calls arrive on
rospy's threads, once per connection or update, never per message.
"""

from __future__ import annotations

import asyncio
import contextlib
import threading
from collections.abc import Callable
from typing import Any

from rospy.impl.registration import RegManager, get_registration_listeners
from rospy.impl.tcpros import get_tcpros_handler

from simbridge.endpoint.backends.ros1.tcpros_sub import SubscribedTopic
from simbridge.errors import EndpointError

__all__ = [
    "BusInfo",
    "add_bus_info",
    "install",
    "remove_bus_info",
    "route_publication",
    "route_subscription",
    "unroute",
]

BusInfo = Callable[[], list[list[Any]]]
"""Rows of the slave API's getBusInfo: [id, peer, direction, "TCPROS", topic, connected, info]."""

_TCPROS = "TCPROS"

_lock = threading.Lock()
_publications: dict[str, tuple[str, int]] = {}
_subscriptions: dict[str, tuple[asyncio.AbstractEventLoop, SubscribedTopic]] = {}
_bus_info: list[BusInfo] = []


class _Handler:
    """rospy's protocol-handler interface, in front of rospy's own TCPROS handler."""

    def __init__(self, inner: Any) -> None:
        self.inner = inner

    def supports(self, protocol: str) -> bool:
        return bool(self.inner.supports(protocol))

    def get_supported(self) -> list[list[str]]:
        supported: list[list[str]] = self.inner.get_supported()
        return supported

    def shutdown(self) -> None:
        self.inner.shutdown()

    def init_publisher(self, resolved_name: str, protocol: list[Any]) -> tuple[int, str, list[Any]]:
        with _lock:
            address = _publications.get(resolved_name)
        if address is None:
            result: tuple[int, str, list[Any]] = self.inner.init_publisher(resolved_name, protocol)
            return result
        if not protocol or protocol[0] != _TCPROS:
            return 0, f"protocol {protocol!r} is not TCPROS", []
        host, port = address
        return 1, f"ready on {host}:{port}", [_TCPROS, host, port]

    def create_transport(
        self, resolved_name: str, pub_uri: str, protocol_params: list[Any]
    ) -> tuple[int, str, int]:
        with _lock:
            route = _subscriptions.get(resolved_name)
        if route is None:
            result: tuple[int, str, int] = self.inner.create_transport(
                resolved_name, pub_uri, protocol_params
            )
            return result
        if (
            not isinstance(protocol_params, list)
            or len(protocol_params) != 3
            or protocol_params[0] != _TCPROS
        ):
            return 0, f"invalid TCPROS parameters {protocol_params!r}", 0
        _, host, port = protocol_params
        loop, topic = route
        try:
            loop.call_soon_threadsafe(topic.connect, pub_uri, str(host), int(port))
        except RuntimeError:  # the loop is closed: the endpoint is going away
            return 0, "the endpoint is shutting down", 0
        return 1, f"connecting {resolved_name} to {host}:{port}", int(port)


def install() -> None:
    """Put the routing handler in front of rospy's TCPROS handler and add the endpoint's
    connections to the node's getBusInfo (once; the node must exist)."""
    for listener in get_registration_listeners().listeners:
        if isinstance(listener, RegManager):
            node: Any = listener.handler
            break
    else:
        raise EndpointError("this process has no registered rospy node")
    manager: Any = listener
    handlers: list[Any] = node.protocol_handlers
    with _lock:
        if not any(isinstance(handler, _Handler) for handler in handlers):
            for index, handler in enumerate(handlers):
                if handler is get_tcpros_handler():
                    handlers[index] = _Handler(handler)
                    break
            else:
                raise EndpointError("rospy's node has no TCPROS handler to route through")
        if "getBusInfo" not in vars(node):
            node.getBusInfo = _bus_info_of(node.getBusInfo)
        if "publisherUpdate" not in vars(node):
            node.publisherUpdate = _publisher_update_of(node.publisherUpdate)
        if "publisher_update" not in vars(manager):
            manager.publisher_update = _publisher_list_of(manager.publisher_update)


def _publisher_update_of(rospy_update: Callable[[str, str, Any], Any]) -> Callable[..., Any]:
    """The slave API's publisherUpdate, also telling the endpoint's topics (rospy's own
    passes nothing on when the list is empty: the last publisher left)."""

    def publisherUpdate(caller_id: str, topic: str, publishers: Any) -> Any:  # noqa: N802
        result = rospy_update(caller_id, topic, publishers)
        if result[0] == 1:
            _tell_publishers(topic, publishers)
        return result

    return publisherUpdate


def _publisher_list_of(rospy_update: Callable[[str, list[str]], None]) -> Callable[..., None]:
    """RegManager.publisher_update (the lists of registrations, updates and rejoins), also
    telling the endpoint's topics."""

    def publisher_update(resolved_name: str, uris: list[str]) -> None:
        _tell_publishers(resolved_name, uris)
        rospy_update(resolved_name, uris)

    return publisher_update


def _tell_publishers(name: str, uris: list[str]) -> None:
    with _lock:
        route = _subscriptions.get(name)
    if route is None:
        return
    loop, topic = route
    with contextlib.suppress(RuntimeError):  # a closed loop: the endpoint is going away
        loop.call_soon_threadsafe(topic.set_publishers, [str(uri) for uri in uris])


def _bus_info_of(rospy_bus_info: Callable[[str], Any]) -> Callable[[str], Any]:
    """getBusInfo answering rospy's connections and the endpoint's (rqt_graph, rosnode info)."""

    def getBusInfo(caller_id: str) -> Any:  # noqa: N802 - the slave API's name
        code, message, rows = rospy_bus_info(caller_id)
        with _lock:
            sources = list(_bus_info)
        return code, message, [*rows, *(row for source in sources for row in source())]

    return getBusInfo


def add_bus_info(source: BusInfo) -> None:
    """Report `source()`'s connections in getBusInfo (called on rospy's XML-RPC thread)."""
    with _lock:
        _bus_info.append(source)


def remove_bus_info(source: BusInfo) -> None:
    with _lock:
        if source in _bus_info:
            _bus_info.remove(source)


def route_publication(name: str, host: str, port: int) -> None:
    """Send subscribers of topic `name` to the endpoint's server at host:port."""
    with _lock:
        _publications[name] = (host, port)


def route_subscription(name: str, loop: asyncio.AbstractEventLoop, topic: SubscribedTopic) -> None:
    """Connect topic `name` to its publishers with `topic`'s connections on `loop`."""
    with _lock:
        _subscriptions[name] = (loop, topic)


def unroute(name: str, *, publication: bool) -> None:
    """Give topic `name` back to rospy (the endpoint no longer publishes/subscribes it)."""
    with _lock:
        if publication:
            _publications.pop(name, None)
        else:
            _subscriptions.pop(name, None)
