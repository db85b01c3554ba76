"""Is a ROS 1 service really there? Ask the master, then the server itself.

The master keeps a service registered after its node dies without unregistering
(kill -9, or SIGTERM on nodes that do not handle it), so a lookup alone can name a
dead server. A probe connection (the TCPROS `probe` header, as `rosservice info`
uses) proves the server answers and tells which node serves it.
"""

from __future__ import annotations

import io
import socket
import urllib.parse
import xmlrpc.client
from typing import Any

from rosgraph.network import (
    ROSHandshakeException,
    read_ros_handshake_header,
    write_ros_handshake_header,
)

from simbridge.errors import EndpointError

__all__ = ["probe_service"]

_CALLER = "/simbridge_probe"


def probe_service(master_uri: str, service: str, timeout: float = 2.0) -> str:
    """The name of the node that serves `service` and answers a probe now.

    Raises EndpointError when the master does not know the service or its registered
    server does not answer (a stale registration).
    """
    try:
        reply: Any = xmlrpc.client.ServerProxy(master_uri).lookupService(_CALLER, service)
    except (OSError, xmlrpc.client.Error) as exc:
        raise EndpointError(f"cannot ask the ROS master at {master_uri}: {exc}") from exc
    code, status, uri = reply
    if code != 1:
        raise EndpointError(f"{service} is not registered with the master: {status}")
    address = urllib.parse.urlparse(str(uri))
    if address.scheme != "rosrpc" or not address.hostname or not address.port:
        raise EndpointError(f"{service} is registered with a malformed address {uri!r}")
    header = {"probe": "1", "md5sum": "*", "callerid": _CALLER, "service": service}
    try:
        with socket.create_connection((address.hostname, address.port), timeout) as sock:
            sock.settimeout(timeout)
            write_ros_handshake_header(sock, header)
            answer: dict[str, str] = read_ros_handshake_header(sock, io.BytesIO(), 4096)
    except (OSError, ValueError, ROSHandshakeException) as exc:
        raise EndpointError(
            f"{service} is registered at {uri} but its server does not answer ({exc}); "
            "a node that died without unregistering leaves such a stale entry"
        ) from exc
    if "error" in answer or "callerid" not in answer:
        raise EndpointError(f"{service} at {uri} refused a probe: {answer.get('error', answer)}")
    return answer["callerid"]
