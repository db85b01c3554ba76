"""Bounded attacks on a running endpoint over loopback, for the memory test and benchmark.

Each attack opens raw sockets, does its harm within a few seconds and leaves its
sockets open (returned) so the endpoint still holds whatever it accepted while the
caller measures; close them with `close_all`. `EndpointProcess` runs `simbridge
endpoint` as a child process and reads its resident memory (current and peak).
"""

from __future__ import annotations

import json
import socket
import struct
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

from benchmarks.procstatus import proc_status
from simbridge.protocol import Publish, TopicListRequest, encode_frame

__all__ = ["ATTACKS", "EndpointProcess", "close_all"]

MIB = 1024 * 1024


class EndpointProcess:
    """`simbridge endpoint --port 0 ARGS...` in a child process; a context manager."""

    def __init__(self, *args: str) -> None:
        self.args = args
        self.proc: subprocess.Popen[str] | None = None
        self.port = 0

    def __enter__(self) -> EndpointProcess:
        cmd = [sys.executable, "-m", "simbridge.cli", "--log-level", "ERROR", "endpoint"]
        self.proc = subprocess.Popen(
            [*cmd, "--port", "0", *self.args], stdout=subprocess.PIPE, text=True
        )
        assert self.proc.stdout is not None
        line = self.proc.stdout.readline()
        self.port = int(line.split("127.0.0.1:")[1].split()[0])
        return self

    def __exit__(self, *exc: object) -> None:
        assert self.proc is not None
        self.proc.terminate()
        try:
            self.proc.wait(10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait(10)

    @property
    def alive(self) -> bool:
        return self.proc is not None and self.proc.poll() is None

    def rss(self) -> int:
        """Resident bytes now."""
        assert self.proc is not None
        return proc_status("VmRSS", self.proc.pid)

    def peak_rss(self) -> int:
        """Peak resident bytes since start or the last `reset_peak()`."""
        assert self.proc is not None
        return proc_status("VmHWM", self.proc.pid)

    def reset_peak(self) -> None:
        """Start a new peak measurement (Linux: clear_refs 5)."""
        assert self.proc is not None
        Path(f"/proc/{self.proc.pid}/clear_refs").write_text("5")


def _connect(port: int) -> socket.socket:
    sock = socket.create_connection(("127.0.0.1", port), timeout=5)
    sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    return sock


def _send_quietly(sock: socket.socket, data: bytes) -> bool:
    try:
        sock.sendall(data)
    except OSError:  # the endpoint closed it (refused, over budget): that is its defence
        return False
    return True


def _wait_processed(port: int) -> None:
    """One round trip on a fresh connection: the endpoint has caught up."""
    with _connect(port) as sock:
        sock.sendall(TopicListRequest().encode())
        sock.settimeout(10)
        data = b""
        while b"__topic_list" not in data:
            chunk = sock.recv(1 << 16)
            if not chunk:
                return
            data += chunk


def declared_big_frames(port: int, connections: int = 24, sent_mib: int = 6) -> list[socket.socket]:
    """Frames declaring 64 MiB, each followed by only `sent_mib` MiB, left incomplete."""
    socks = []
    head = struct.pack("<I", 4) + b"/big" + struct.pack("<I", 64 * MIB)
    body = b"\x01" * (sent_mib * MIB)
    for _ in range(connections):
        sock = _connect(port)
        sock.settimeout(2)
        socks.append(sock)
        if _send_quietly(sock, head):
            _send_quietly(sock, body)
    _wait_processed(port)
    return socks


def slow_subscriber(port: int, messages: int = 300, size: int = MIB) -> list[socket.socket]:
    """A subscriber with the largest queue_size that never reads, fed `messages` x `size`."""
    sub = _connect(port)
    sub.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 64 * 1024)
    body = {"topic": "/flood", "message_name": "std_msgs/String", "queue_size": 10_000}
    sub.sendall(encode_frame("__subscribe", json.dumps(body).encode()))
    _wait_processed(port)
    pub = _connect(port)
    pub.sendall(Publish("/flood", "std_msgs/String").encode())
    blob = struct.pack("<I", size - 4) + b"y" * (size - 4)
    frame = encode_frame("/flood", blob)
    for _ in range(messages):
        if not _send_quietly(pub, frame):
            break
    _wait_processed(port)
    return [sub, pub]


def unread_topic_lists(
    port: int, topics: int = 2_000, requests: int = 1_000
) -> list[socket.socket]:
    """Many long topic names, then `__topic_list` requests whose replies are never read."""
    sock = _connect(port)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 64 * 1024)
    prefix = "/" + "t" * 240
    sock.sendall(
        b"".join(Publish(f"{prefix}{i}", "std_msgs/String").encode() for i in range(topics))
    )
    request = TopicListRequest().encode()
    for _ in range(requests):
        if not _send_quietly(sock, request):
            break
    _wait_processed(port)
    return [sock]


def long_unregistered_names(port: int, frames: int = 400) -> list[socket.socket]:
    """Messages on unregistered 60 KB topic names (each error would echo the name)."""
    sock = _connect(port)
    for i in range(frames):
        if not _send_quietly(sock, encode_frame(f"/{i}" + "n" * 60_000, b"x")):
            break
    _wait_processed(port)
    return [sock]


def close_all(socks: list[socket.socket]) -> None:
    """Close the attack's sockets."""
    for sock in socks:
        sock.close()
    time.sleep(0.2)


ATTACKS: dict[str, Callable[[int], list[socket.socket]]] = {
    "24 frames declaring 64 MiB, 6 MiB sent": declared_big_frames,
    "slow subscriber, queue_size 10000, 300 x 1 MiB": slow_subscriber,
    "1,000 unread __topic_list of 2,000 long topics": unread_topic_lists,
    "400 messages on unregistered 60 KB names": long_unregistered_names,
}
"""Name -> attack; each takes the endpoint's port and returns its open sockets."""
