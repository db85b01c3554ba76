"""open_link: a link to an endpoint on this machine uses unpaced congestion control."""

from __future__ import annotations

import socket
from pathlib import Path

import pytest

from simbridge.connector.link import open_link
from simbridge.tcp import LOOPBACK_CONGESTION

_ALLOWED = Path("/proc/sys/net/ipv4/tcp_allowed_congestion_control")


def _congestion(sock: socket.socket) -> bytes:
    raw = sock.getsockopt(socket.IPPROTO_TCP, socket.TCP_CONGESTION, 16)
    return raw.split(b"\0", 1)[0]


@pytest.mark.skipif(not hasattr(socket, "TCP_CONGESTION"), reason="Linux only")
def test_a_loopback_link_is_not_paced() -> None:
    if LOOPBACK_CONGESTION.decode() not in _ALLOWED.read_text().split():
        pytest.skip(f"{LOOPBACK_CONGESTION!r} is not allowed on this system")
    with socket.create_server(("127.0.0.1", 0)) as server:
        link = open_link("127.0.0.1", server.getsockname()[1], timeout=5.0)
        accepted, _ = server.accept()
        try:
            assert _congestion(link.sock) == LOOPBACK_CONGESTION
            assert link.sock.getsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY)
            link.sock.sendall(b"ping")
            assert accepted.recv(4) == b"ping"
        finally:
            accepted.close()
            link.close()
