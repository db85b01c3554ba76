"""simbridge.tcp: both ends of a loopback ROS-TCP connection send unpaced, others keep the
system's default congestion control."""

from __future__ import annotations

import socket
import time
from pathlib import Path

import pytest

from simbridge.endpoint import EndpointOptions, EndpointThread
from simbridge.tcp import LOOPBACK_CONGESTION, is_loopback_peer, set_congestion, tune_stream

_ALLOWED = Path("/proc/sys/net/ipv4/tcp_allowed_congestion_control")
_DEFAULT = Path("/proc/sys/net/ipv4/tcp_congestion_control")

linux_only = pytest.mark.skipif(not hasattr(socket, "TCP_CONGESTION"), reason="Linux only")


def _congestion(sock: socket.socket) -> bytes:
    raw = sock.getsockopt(socket.IPPROTO_TCP, socket.TCP_CONGESTION, 16)
    return raw.split(b"\0", 1)[0]


def _require_loopback_congestion() -> None:
    if LOOPBACK_CONGESTION.decode() not in _ALLOWED.read_text().split():
        pytest.skip(f"{LOOPBACK_CONGESTION!r} is not allowed on this system")
    if _DEFAULT.read_bytes().strip() == LOOPBACK_CONGESTION:
        pytest.skip(f"{LOOPBACK_CONGESTION!r} is this system's default: nothing to tell apart")


@pytest.mark.parametrize(
    ("peer", "loopback"),
    [
        (("127.0.0.1", 5000), True),
        (("127.3.4.5", 5000), True),
        (("::1", 5000, 0, 0), True),
        (("::ffff:127.0.0.1", 5000, 0, 0), True),
        (("::ffff:10.0.0.1", 5000, 0, 0), False),
        (("10.0.0.1", 5000), False),
        (("192.168.1.7", 5000), False),
        (("fe80::1%eth0", 5000, 0, 2), False),
        ("/tmp/some.sock", False),
        (("not an address", 1), False),
        ((), False),
    ],
)
def test_loopback_peer(peer: object, loopback: bool) -> None:
    assert is_loopback_peer(peer) is loopback


@linux_only
def test_unknown_congestion_leaves_the_default() -> None:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        before = _congestion(sock)
        set_congestion(sock, b"no-such-algorithm")
        assert _congestion(sock) == before == _DEFAULT.read_bytes().strip()


@linux_only
def test_a_non_loopback_peer_keeps_the_default() -> None:
    """tune_stream asks the socket for its peer: one that is not loopback (as getpeername
    reports a remote client) gets Nagle off and nothing else."""

    class _Remote:
        def __init__(self, sock: socket.socket) -> None:
            self.sock = sock

        def setsockopt(self, *args: object) -> None:
            self.sock.setsockopt(*args)  # type: ignore[call-overload]

        def getpeername(self) -> tuple[str, int]:
            return ("192.0.2.10", 40000)  # TEST-NET-1: never reached, only reported

    with (
        socket.create_server(("127.0.0.1", 0)) as server,
        socket.create_connection(server.getsockname()) as sock,
    ):
        before = _congestion(sock)
        tune_stream(_Remote(sock))
        assert sock.getsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY)
        assert _congestion(sock) == before == _DEFAULT.read_bytes().strip()


@linux_only
def test_the_endpoint_sends_to_a_loopback_client_unpaced() -> None:
    _require_loopback_congestion()
    with (
        EndpointThread(EndpointOptions(port=0)) as endpoint,
        socket.create_connection(("127.0.0.1", endpoint.port), timeout=5) as client,
    ):
        assert client.recv(1)  # the handshake: the session is set up
        deadline = time.monotonic() + 5
        while not endpoint.server.sessions and time.monotonic() < deadline:
            time.sleep(0.01)
        (session,) = endpoint.server.sessions
        assert session.transport is not None
        accepted = session.transport.get_extra_info("socket")
        assert _congestion(accepted) == LOOPBACK_CONGESTION
        assert accepted.getsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY)
        # the client's own socket was not tuned: the endpoint's choice is its own
        assert _congestion(client) == _DEFAULT.read_bytes().strip()
