"""One TCP connection to the endpoint, shared by the connector's reader and writer."""

from __future__ import annotations

import contextlib
import socket
import threading

from simbridge.tcp import tune_stream

__all__ = ["Link", "open_link"]


class Link:
    """A connected socket. `fail()` wakes any thread blocked on it; `close()` releases it."""

    def __init__(self, sock: socket.socket) -> None:
        self.sock = sock
        self.send_lock = threading.Lock()
        """Held by the writer while it sends, so `close()` never frees a socket in use."""
        self.broken = False
        """Set once by `fail()` (a plain flag: every read and send checks it)."""

    def fail(self) -> None:
        """Mark broken and shut the socket down (blocked reads and writes return at once)."""
        if self.broken:
            return
        self.broken = True
        with contextlib.suppress(OSError):
            self.sock.shutdown(socket.SHUT_RDWR)

    def half_close(self) -> None:
        """Send FIN once everything written so far is out; reading goes on."""
        with contextlib.suppress(OSError):
            self.sock.shutdown(socket.SHUT_WR)

    def close(self) -> None:
        """Shut down, wait for a send in progress to give up, then close the socket."""
        self.fail()
        with self.send_lock:
            self.sock.close()


def open_link(host: str, port: int, timeout: float) -> Link:
    """Connect with a timeout; the socket is then blocking, tuned by `simbridge.tcp`
    (Nagle's delay off, unpaced congestion control when the endpoint is on this machine)."""
    sock = socket.create_connection((host, port), timeout=timeout)
    try:
        sock.settimeout(None)
        tune_stream(sock)
    except OSError:
        sock.close()
        raise
    return Link(sock)
