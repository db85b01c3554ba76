"""Join a restarted ROS 1 master again: roscore killed and started anew forgets every node.

rospy registers a node's publishers, subscribers and services once, when each is made;
a master that restarts (same URI, empty state) never hears of them again, so
`rostopic echo` finds no publisher and `rosservice call` no service. `MasterWatch`
asks the master every `period` seconds who it is (pid and /run_id); when a new master
answers that does not know this node (`lookupNode`), it registers everything rospy
holds again and hands each subscription the publishers the master names, as rospy
does at startup.
"""

from __future__ import annotations

import logging
import threading
import xmlrpc.client
from typing import Any

import rospy
from rospy.impl.registration import (
    RegManager,
    get_registration_listeners,
    get_service_manager,
    get_topic_manager,
)

from simbridge.errors import EndpointError

__all__ = ["MAX_REMEMBERED_PARAMS", "MasterWatch", "register_again", "remember_param"]

_log = logging.getLogger("simbridge.endpoint.ros1")

MAX_REMEMBERED_PARAMS = 10_000
"""Parameters set through this node that a restarted master is given again, at most."""
_params: dict[str, Any] = {}
_params_lock = threading.Lock()


def remember_param(name: str, value: Any) -> bool:
    """Note a parameter (resolved name) this node set, to set it again on a restarted
    master, which starts with none. False (not remembered) past MAX_REMEMBERED_PARAMS."""
    with _params_lock:
        if name not in _params and len(_params) >= MAX_REMEMBERED_PARAMS:
            return False
        _params[name] = value
        return True


def _reg_manager() -> RegManager:
    """rospy's registration manager of this process's node (it keeps the node's URI)."""
    for listener in get_registration_listeners().listeners:
        if isinstance(listener, RegManager):
            return listener
    raise EndpointError("this process has no registered rospy node")


def _held() -> tuple[list[tuple[str, str]], list[tuple[str, str]], list[tuple[str, str]]]:
    """(topic, type) published, (topic, type) subscribed, (service, URI) served by rospy."""
    topics = get_topic_manager()
    with topics.lock:
        publications = [(name, kind) for name, kind in topics.get_publications()]
        subscriptions = [(name, kind) for name, kind in topics.get_subscriptions()]
    services = [(name, uri) for name, uri in get_service_manager().get_services()]
    return publications, subscriptions, services


def _still_running() -> None:
    if rospy.core.is_shutdown_requested():
        raise EndpointError("the node is shutting down; not registering it again")


def register_again(master_uri: str) -> tuple[int, int, int]:
    """Register every publisher, subscriber and service of this node with the master, and
    set the parameters it set (`remember_param`); returns how many publishers, subscribers
    and services. Subscribers connect to the publishers the master names."""
    caller = rospy.get_caller_id()
    manager = _reg_manager()
    node_uri = manager.uri
    publications, subscriptions, services = _held()
    master: Any = xmlrpc.client.ServerProxy(master_uri)
    for name, msg_type in publications:
        _still_running()
        master.registerPublisher(caller, name, msg_type, node_uri)
    for name, msg_type in subscriptions:
        _still_running()
        code, _, publishers = master.registerSubscriber(caller, name, msg_type, node_uri)
        if code == 1:
            manager.publisher_update(name, publishers)
    for name, service_uri in services:
        _still_running()
        master.registerService(caller, name, service_uri, node_uri)
    with _params_lock:
        params = list(_params.items())
    for name, value in params:
        _still_running()
        master.setParam(caller, name, value)
    # Withdraw what was closed meanwhile (its own unregistration may have come first).
    still_published, still_subscribed, still_served = (set(held) for held in _held())
    for entry in set(publications) - still_published:
        master.unregisterPublisher(caller, entry[0], node_uri)
    for entry in set(subscriptions) - still_subscribed:
        master.unregisterSubscriber(caller, entry[0], node_uri)
    for name, service_uri in set(services) - still_served:
        master.unregisterService(caller, name, service_uri)
    return len(publications), len(subscriptions), len(services)


class MasterWatch:
    """A daemon thread that registers this node again when the master restarted.

    A restart shows as a new master identity (its pid and the `/run_id` roscore sets)
    at the same URI. The node registers again only if that master does not know it,
    and never while it is shutting down: registering a name another node took would
    make the master shut the newcomer down in turn.
    """

    def __init__(self, master_uri: str, period: float = 0.5) -> None:
        self.master_uri = master_uri
        self.period = period
        self.rejoined = 0
        """How many times the node was registered again."""
        self._identity = self._master_identity()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="simbridge-ros1-watch", daemon=True)

    def start(self) -> MasterWatch:
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()

    def _run(self) -> None:
        while not self._stop.wait(self.period) and not rospy.core.is_shutdown_requested():
            try:
                self.check()
            except Exception:  # the master went away mid-way: try again next period
                _log.debug("master check failed", exc_info=True)

    def _master_identity(self) -> tuple[int, str] | None:
        """(pid, /run_id) of the master answering now, or None when none answers."""
        master: Any = xmlrpc.client.ServerProxy(self.master_uri)
        caller = rospy.get_caller_id()
        try:
            code, _, pid = master.getPid(caller)
            if code != 1:
                return None
            code, _, run_id = master.getParam(caller, "/run_id")
        except (OSError, xmlrpc.client.Error):
            return None
        return int(pid), str(run_id) if code == 1 else ""

    def check(self) -> bool:
        """Register again if a new master answers that does not know this node."""
        identity = self._master_identity()
        if identity is None or identity == self._identity:
            return False  # down, or the same master as before
        master: Any = xmlrpc.client.ServerProxy(self.master_uri)
        code, _, _ = master.lookupNode(rospy.get_caller_id(), rospy.get_name())
        if code == 1 or rospy.core.is_shutdown_requested():
            self._identity = identity  # it knows us (or someone took the name): leave it
            return False
        counts = register_again(self.master_uri)
        self._identity = identity
        self.rejoined += 1
        _log.warning(
            "the ROS master at %s restarted and did not know %s: registered %d publisher(s), "
            "%d subscriber(s) and %d service(s) again and set %d parameter(s)",
            self.master_uri,
            rospy.get_name(),
            *counts,
            len(_params),
        )
        return True
