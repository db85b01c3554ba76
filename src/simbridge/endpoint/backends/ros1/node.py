"""The process's one rospy node: joining a ROS 1 master and reading its parameters.

rospy allows a single node per process and cannot re-initialise it, so every
Ros1Backend in a process shares the node joined first; asking for another
name or master is an error rather than a silent reuse. A MasterWatch registers the
node's topics and services again whenever the master restarts.
"""

from __future__ import annotations

import logging
import os
import socket
import sys
import threading
import urllib.parse
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import rosgraph
import rospy

from simbridge.endpoint.backends.ros1.rejoin import MasterWatch
from simbridge.errors import EndpointError

__all__ = [
    "NodeIdentity",
    "join_graph",
    "leave_graph",
    "on_node_shutdown",
    "read_drop_in_params",
    "ros_args",
]


@dataclass(frozen=True, slots=True)
class NodeIdentity:
    """Who the node is: its base name, ROS command-line args and master."""

    name: str
    ros_args: tuple[str, ...]
    master_uri: str


_lock = threading.Lock()
_joined: NodeIdentity | None = None


def ros_args(argv: Sequence[str]) -> tuple[str, ...]:
    """The ROS remapping and private-param arguments (`a:=b`, `_tcp_port:=10000`) of argv."""
    return tuple(arg for arg in argv if ":=" in arg)


def join_graph(name: str, args: Sequence[str], connect_timeout: float) -> NodeIdentity:
    """Register this process with the master as node `name` (once); blocking.

    The master comes from `__master:=` in args or ROS_MASTER_URI; ROS_HOSTNAME
    and ROS_IP choose the address other nodes use to reach this one.
    """
    global _joined
    base = name.lstrip("/")
    if not base or "/" in base:
        raise EndpointError(f"node name {name!r} must be a base name such as 'simbridge_endpoint'")
    argv = [sys.argv[0], *args]
    master_uri = rosgraph.get_master_uri(argv=argv)
    wanted = NodeIdentity(base, tuple(args), master_uri)
    with _lock:
        if _joined is not None:
            if _joined != wanted:
                raise EndpointError(
                    f"this process is already the ROS node {_joined.name!r} on "
                    f"{_joined.master_uri}; rospy allows one node per process, "
                    f"cannot also join as {base!r} on {master_uri}"
                )
            return _joined
        if rospy.core.is_shutdown_requested():
            raise EndpointError("rospy was shut down in this process; start a new process")
        _wait_for_master(master_uri, connect_timeout)
        # rospy reads the master from os.environ or sys.argv only: make `__master:=` in
        # args count too (the process has one node, so one master, anyway).
        os.environ["ROS_MASTER_URI"] = master_uri
        root = logging.getLogger()
        handlers, level = list(root.handlers), root.level
        try:
            rospy.init_node(base, argv=argv, anonymous=False, disable_signals=True)
        except (rospy.ROSException, ValueError) as exc:
            raise EndpointError(f"cannot join ROS master {master_uri} as {base!r}: {exc}") from exc
        finally:
            # rospy's logging config replaces the root handlers with its log file: keep the
            # application's handlers (console) and level, and add rospy's file beside them.
            added = [h for h in root.handlers if h not in handlers]
            root.handlers = [*handlers, *added]
            root.setLevel(level)
        _joined = wanted
        MasterWatch(master_uri).start()  # re-registers everything if the master restarts
        return wanted


def leave_graph(master_uri: str, reason: str) -> bool:
    """Shut this process's node down if it joined `master_uri`, so rospy unregisters while
    that master still answers: call it before stopping a master the process started (else
    rospy warns at exit that it cannot unregister). The node cannot join again; returns
    whether it was shut down here."""
    with _lock:
        if _joined is None or _joined.master_uri != master_uri:
            return False
        if rospy.core.is_shutdown_requested():
            return False
    rospy.signal_shutdown(reason)
    return True


def on_node_shutdown(callback: Callable[[str], None]) -> None:
    """Call `callback(reason)` on a rospy thread when this process's node shuts down.

    The master shuts a node down when another registers with the same name; rospy then
    stops talking to the graph, so whoever serves clients through it must be told.
    rospy has already unregistered the node's topics and services by then.
    """
    rospy.core.add_preshutdown_hook(callback)


def _wait_for_master(master_uri: str, timeout: float) -> None:
    """Fail fast (instead of rospy's endless retry) when no master answers."""
    url = urllib.parse.urlparse(master_uri)
    if not url.hostname or not url.port:
        raise EndpointError(f"ROS master URI {master_uri!r} must look like http://host:11311/")
    try:
        with socket.create_connection((url.hostname, url.port), timeout=timeout):
            pass
    except OSError as exc:
        raise EndpointError(
            f"no ROS master at {master_uri} ({exc}); start roscore or set ROS_MASTER_URI"
        ) from exc


def read_drop_in_params() -> tuple[str | None, int | None]:
    """The original ros_tcp_endpoint node's private params `~tcp_ip` and `~tcp_port`.

    Call it after a Ros1Backend has started (the node must exist); absent params are None.
    """
    if not rospy.core.is_initialized():
        raise EndpointError("read_drop_in_params() needs the ROS node: start a Ros1Backend first")
    host = rospy.get_param("~tcp_ip", None)
    port = rospy.get_param("~tcp_port", None)
    if host is not None and not isinstance(host, str):
        raise EndpointError(f"~tcp_ip must be a host name or address string, got {host!r}")
    if port is not None:
        try:
            port = int(port)
        except (TypeError, ValueError) as exc:
            raise EndpointError(f"~tcp_port must be an integer 0-65535, got {port!r}") from exc
        if not 0 <= port <= 65535:
            raise EndpointError(f"~tcp_port must be an integer 0-65535, got {port!r}")
    return host, port
