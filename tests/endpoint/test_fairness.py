"""Fairness under attack: slow senders are closed, a full endpoint makes room for real
clients, error floods are rate limited, drop warnings add up, and a canary pair of
connectors keeps exchanging messages with no loss while all of it happens."""

from __future__ import annotations

import contextlib
import json
import re
import socket
import struct
import threading
import time
from collections.abc import Callable, Iterator

import pytest

from simbridge.connector import Connector
from simbridge.endpoint import EndpointOptions, EndpointThread
from simbridge.messages import default_registry
from simbridge.protocol import (
    CommandReceived,
    ErrorMessage,
    Handshake,
    Publish,
    TopicListReply,
    TopicListRequest,
    WarnMessage,
    encode_frame,
)
from tests.endpoint.rawclient import RawClient
from tests.waiting import wait_for


def is_cmd(cls: type) -> Callable[[object], bool]:
    return lambda e: isinstance(e, CommandReceived) and isinstance(e.command, cls)


def sync(client: RawClient) -> None:
    client.send(TopicListRequest().encode())
    client.expect(is_cmd(TopicListReply))


def _drip(port: int) -> socket.socket:
    """A connection that starts a frame and then sends nothing more of it."""
    sock = socket.create_connection(("127.0.0.1", port), timeout=5)
    sock.sendall(struct.pack("<I", 6) + b"/dr")
    return sock


def test_slow_sender_is_closed_with_an_error() -> None:
    options = EndpointOptions(
        port=0, frame_timeout=0.5, min_frame_rate=1000, keepalive_interval=0.1
    )
    with EndpointThread(options) as ep:
        slow = RawClient(ep.port)
        slow.send(struct.pack("<I", 6) + b"/sl")
        for _ in range(8):  # a byte every 0.15 s: never idle, never done
            time.sleep(0.15)
            try:
                slow.send(b"o")
            except OSError:
                break
        text = slow.expect(is_cmd(ErrorMessage), timeout=5).command.text
        assert "frame not completed within 0.5 s" in text
        assert slow.closed_by_peer()


def test_steady_slow_stream_of_complete_frames_is_not_closed() -> None:
    options = EndpointOptions(
        port=0, frame_timeout=1.0, min_frame_rate=10**6, keepalive_interval=0.1
    )
    with EndpointThread(options) as ep:
        client = RawClient(ep.port)
        client.send(Publish("/slow", "std_msgs/String").encode())
        frame = encode_frame("/slow", struct.pack("<I", 1) + b"x")
        # each frame completes in two halves, 0.1 s apart (a busy box may stretch that
        # tenfold before the frame timeout); the whole stream lasts past the timeout
        for _ in range(15):
            client.send(frame[:5])
            time.sleep(0.1)
            client.send(frame[5:])
        sync(client)


def test_drip_connections_cannot_lock_out_real_clients() -> None:
    options = EndpointOptions(port=0, max_clients=10, evict_after=0.3, frame_timeout=30)
    with EndpointThread(options) as ep:
        drips = [_drip(ep.port) for _ in range(10)]
        assert wait_for(lambda: ep.call(ep.server.stats)["clients"] == 10, timeout=10)
        time.sleep(0.5)  # every drip has been connected longer than evict_after
        real = RawClient(ep.port)  # evicts the oldest drip instead of being refused
        real.expect(is_cmd(Handshake))
        sync(real)
        proven = [RawClient(ep.port) for _ in range(9)]
        for client in proven:
            sync(client)
        # Now every slot holds a client that sent a request: a new one is refused.
        late = RawClient(ep.port)
        assert "endpoint full" in late.expect(is_cmd(ErrorMessage)).command.text
        assert late.closed_by_peer()
        for sock in drips:
            sock.close()


def test_unregistered_topic_errors_are_rate_limited_per_client() -> None:
    options = EndpointOptions(port=0, warn_interval=60.0, max_errors_per_interval=10)
    with EndpointThread(options) as ep:
        client = RawClient(ep.port)
        client.send(b"".join(encode_frame(f"/junk{i}", b"x") for i in range(10_000)))
        sync(client)
        stats = client.stats()
        assert stats["session"]["errors_sent"] == 10
        errors = [e for e in client.events if is_cmd(ErrorMessage)(e)]
        assert len(errors) == 10


def test_drop_warnings_add_up_to_the_drops() -> None:
    options = EndpointOptions(port=0, write_high_water=64 * 1024, warn_interval=0.2)
    with EndpointThread(options) as ep:
        slow = RawClient(ep.port)
        slow.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 32 * 1024)
        body = {"topic": "/img", "message_name": "std_msgs/String", "queue_size": 5}
        slow.send(encode_frame("__subscribe", json.dumps(body).encode()))
        sync(slow)
        pub = RawClient(ep.port)
        pub.send(Publish("/img", "std_msgs/String").encode())
        blob = struct.pack("<I", 100_000) + b"x" * 100_000
        for burst in range(3):  # drops in several intervals, the last burst at the end of one
            for _ in range(60):
                pub.send(encode_frame("/img", blob))
            time.sleep(0.05 if burst < 2 else 0)
        sync(pub)
        dropped = ep.call(ep.server.stats)["dropped_total"]
        assert dropped > 0
        time.sleep(0.5)  # the last interval's summary is sent after it ends
        reported = 0
        deadline = time.monotonic() + 10
        while reported < dropped and time.monotonic() < deadline:
            warn = slow.expect(is_cmd(WarnMessage), timeout=10).command.text
            reported += int(re.search(r"dropped (\d+) message", warn)[1])  # type: ignore[index]
        assert reported == dropped


@pytest.fixture
def canary_endpoint() -> Iterator[EndpointThread]:
    options = EndpointOptions(
        port=0, max_clients=40, frame_timeout=1.0, evict_after=0.5, max_memory=256 * 1024 * 1024
    )
    with EndpointThread(options) as ep:
        yield ep


def _attacks(port: int, stop: threading.Event) -> None:
    """Every attack of issue 15, repeated until `stop`."""
    socks: list[socket.socket] = []
    big_name = json.dumps({"topic": "/t", "message_name": "x/" + "Y" * 900_000}).encode()
    while not stop.is_set():
        for payload in (
            encode_frame("__publish", big_name),
            encode_frame("__subscribe", b"[" * 100_000),
            encode_frame("__subscribe", b'{"queue_size": ' + b"9" * 5000 + b"}"),
            b"".join(encode_frame(f"/junk{i}", b"x") for i in range(2000)),
            struct.pack("<I", 4) + b"/big" + struct.pack("<I", 64 << 20) + b"z" * (1 << 20),
        ):
            try:
                sock = socket.create_connection(("127.0.0.1", port), timeout=2)
                sock.sendall(payload)
                socks.append(sock)
            except OSError:
                pass
        for _ in range(5):
            with contextlib.suppress(OSError):
                socks.append(_drip(port))
        while len(socks) > 30:
            socks.pop(0).close()
        stop.wait(0.1)
    for sock in socks:
        sock.close()


def test_canary_pair_loses_nothing_while_attacked(canary_endpoint: EndpointThread) -> None:
    """Every canary message arrives, in order, while every attack runs; none waits long
    behind the attacks. Waiting is measured per message from its publish to its arrival,
    so a publishing thread the machine was slow to wake (the gaps between publishes)
    does not count against the endpoint."""
    reg = default_registry()
    port = canary_endpoint.port
    sent_at: list[float] = []
    arrivals: list[tuple[int, float]] = []
    with (
        Connector("127.0.0.1", port).connect() as sub,
        Connector("127.0.0.1", port).connect() as pub,
    ):
        sub.subscribe(
            "/canary",
            "std_msgs/UInt32",
            lambda payload: arrivals.append((struct.unpack("<I", payload)[0], time.monotonic())),
            raw=True,
        )
        publisher = pub.register_publisher("/canary", "std_msgs/UInt32")
        assert sub.flush(5)
        sub.endpoint_stats()  # a barrier: the endpoint holds the subscription
        stop = threading.Event()
        attacker = threading.Thread(target=_attacks, args=(port, stop), daemon=True)
        attacker.start()
        try:
            t_end = time.monotonic() + 4.0
            while time.monotonic() < t_end:  # 100 Hz
                sent_at.append(time.monotonic())
                publisher.publish(reg.encode(reg.new("std_msgs/UInt32", data=len(sent_at) - 1)))
                time.sleep(0.01)
        finally:
            stop.set()
            attacker.join(10)
        assert wait_for(lambda: len(arrivals) >= len(sent_at), timeout=10)
        assert sub.connected
        assert pub.connected
    assert [seq for seq, _ in arrivals] == list(range(len(sent_at)))
    waits = [at - sent_at[seq] for seq, at in arrivals]
    assert max(waits) < 2.0, f"a canary message waited {max(waits):.3f} s behind the attacks"
