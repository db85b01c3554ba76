"""A ROS publisher connection that streams small messages is read in batches (its reads
coalesced), while a request/reply exchange, lone messages and a large message arriving in
chunks are read at once; nothing is lost or reordered either way."""

from __future__ import annotations

import asyncio
import socket
import struct
import threading
import time
from collections.abc import Callable, Sequence

from simbridge.endpoint.backends.ros1.raw import RawMessageType
from simbridge.endpoint.backends.ros1.tcpros_sub import COALESCE, Sink, SubscribedTopic
from simbridge.protocol.tcpros import TcprosDecoder, encode_header, frame

INFO = RawMessageType("std_msgs/UInt32", "304a39449588c7f8ce2df6e8001c5fce", "uint32 data\n")

Plan = Callable[[socket.socket, threading.Event], None]
"""What the publisher sends once connected; the event is set by each delivery."""


def _publisher(plan: Plan, delivered: threading.Event) -> tuple[int, threading.Thread]:
    """A TCPROS publisher on a free port that answers one subscriber's header, then runs
    `plan` on the connection."""
    server = socket.create_server(("127.0.0.1", 0))

    def serve() -> None:
        with server:
            server.settimeout(10)
            conn, _ = server.accept()
        with conn:
            conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            decoder = TcprosDecoder(1 << 20)
            while decoder.header is None:
                decoder.feed(conn.recv(65536))
            fields = {"callerid": "/pub", "md5sum": INFO.md5sum, "type": INFO.name}
            conn.sendall(encode_header({**fields, "topic": decoder.header["topic"]}))
            plan(conn, delivered)
            time.sleep(0.5)

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    return server.getsockname()[1], thread


def _receive(
    plan: Plan, count: int, marks: list[int] | None = None, sink: Sink | None = None
) -> tuple[list[bytes], int]:
    """Subscribe over one real TCPROS connection to a publisher running `plan`; returns
    the payloads delivered (once `count` arrived) and how often reading paused (and in
    `marks`, how often it had paused when each payload was delivered)."""
    delivered = threading.Event()
    port, thread = _publisher(plan, delivered)
    got: list[bytes] = []
    marks = [] if marks is None else marks

    async def main() -> int:
        topic = SubscribedTopic("/t", INFO, "/sub", 1 << 24)

        def on_message(payload: bytes) -> None:
            got.append(payload)
            marks.append(topic.coalesced)
            delivered.set()

        if sink is None:
            topic.sinks.append(Sink(on_message))
        else:
            sink.callback = on_message
            topic.sinks.append(sink)
            blocked = sink.blocked

            async def unblock() -> None:  # as a session does once its client reads again
                while topic.sinks:
                    await asyncio.sleep(0.005)
                    if blocked is not None and not blocked():
                        topic.unblocked()

            unblocking = asyncio.ensure_future(unblock())
        topic.connect("http://pub:1/", "127.0.0.1", port)
        deadline = time.monotonic() + 30
        while len(got) < count and time.monotonic() < deadline:
            await asyncio.sleep(0.01)
        topic.close()
        if sink is not None:
            await unblocking
        return topic.coalesced

    coalesced = asyncio.run(main())
    thread.join(10)
    return got, coalesced


def _numbered(count: int) -> list[bytes]:
    return [struct.pack("<I", i) for i in range(count)]


BATCH = 50
"""Messages per write of a paced stream."""


def _send_paced(
    conn: socket.socket, messages: list[bytes], marks: list[int], until_paused: bool = False
) -> int:
    """Send `messages` in writes of BATCH, each once the one before was delivered (`marks`
    grows by one per delivery), so every read brings several messages and the connection
    is a stream whatever the machine's speed: sent one write per message, a reader that
    keeps up reads them one at a time and never sees a stream (it failed so on a fast
    machine), and sent flat out, they can all arrive in one read. Returns how many were
    sent: all, or with `until_paused` those sent until reading had paused once."""
    for start in range(0, len(messages), BATCH):
        batch = messages[start : start + BATCH]
        conn.sendall(b"".join(frame(payload) for payload in batch))
        deadline = time.monotonic() + 10
        while len(marks) < start + len(batch):
            assert time.monotonic() < deadline, f"{len(marks)} of {start + len(batch)} delivered"
            time.sleep(0.001)
        if until_paused and marks[-1] > 0:
            return start + len(batch)
    return len(messages)


def test_a_stream_is_read_in_batches_whole_and_in_order() -> None:
    messages = _numbered(3000)
    marks: list[int] = []

    def stream(conn: socket.socket, _delivered: threading.Event) -> None:
        _send_paced(conn, messages, marks)

    got, coalesced = _receive(stream, len(messages), marks)
    assert got == messages
    assert coalesced > 0


def test_requests_and_replies_and_lone_messages_are_never_held() -> None:
    messages = _numbered(60)

    def ping_pong(conn: socket.socket, delivered: threading.Event) -> None:
        for i, payload in enumerate(messages):
            delivered.clear()
            conn.sendall(frame(payload))
            assert delivered.wait(10)
            # a reply needs at least a round trip through the client and back; lone
            # messages come far apart
            time.sleep(0.0003 if i < 50 else 0.02)

    got, coalesced = _receive(ping_pong, len(messages))
    assert got == messages
    assert coalesced == 0


def test_a_large_message_in_chunks_is_not_a_stream() -> None:
    images = [bytes([i]) * (1 << 20) for i in range(8)]

    def chunked(conn: socket.socket, _delivered: threading.Event) -> None:
        for image in images:
            data = frame(image)
            for start in range(0, len(data), 16384):
                conn.sendall(data[start : start + 16384])
            time.sleep(COALESCE * 4)

    got, coalesced = _receive(chunked, len(images))
    assert got == images
    assert coalesced == 0


def test_the_stream_ends_with_the_burst() -> None:
    """Lone messages after a burst are read as they come: no pause after any of them.

    The burst is 2,000 messages sent paced (`_send_paced`), so it is a stream whatever the
    machine's speed."""
    messages = _numbered(2005)
    marks: list[int] = []

    def burst_then_lone(conn: socket.socket, delivered: threading.Event) -> None:
        _send_paced(conn, messages[:2000], marks)
        for payload in messages[2000:]:
            time.sleep(0.05)
            delivered.clear()
            conn.sendall(frame(payload))
            assert delivered.wait(10)

    got, coalesced = _receive(burst_then_lone, len(messages), marks)
    assert got == messages
    assert marks[2000] > 0  # the burst was coalesced
    assert marks[2000:] == [coalesced] * 5  # and none of the lone messages paused reading


def test_a_consumer_of_batches_gets_a_stream_in_batches_and_may_take_part() -> None:
    """A sole consumer taking batches gets a streaming read's messages in one call; when
    it takes only the first ones (it became blocked), the rest wait, and nothing is lost
    or reordered."""
    messages = _numbered(3000)
    batches: list[int] = []
    calls = 0
    block_until = 0.0

    def take(payloads: Sequence[bytes]) -> int:
        nonlocal calls, block_until
        calls += 1
        batches.append(len(payloads))
        taken = 1 if calls % 5 == 0 else len(payloads)  # now and then: blocked after one
        for payload in list(payloads)[:taken]:
            sink.callback(payload)
        if taken < len(payloads):
            block_until = time.monotonic() + 0.002
        return taken

    sink = Sink(lambda _payload: None, lambda: time.monotonic() < block_until, take)
    marks: list[int] = []

    def stream(conn: socket.socket, _delivered: threading.Event) -> None:
        _send_paced(conn, messages, marks)

    got, _ = _receive(stream, len(messages), marks, sink=sink)
    assert got == messages
    assert max(batches) > 1


def test_a_stream_that_ends_with_the_connection_arrives_whole() -> None:
    """The publisher closes right after a burst, once reading paused (a stream): every
    message still arrives, in order."""
    messages = _numbered(4000)
    marks: list[int] = []

    def stream_and_close(conn: socket.socket, _delivered: threading.Event) -> None:
        sent = _send_paced(conn, messages, marks, until_paused=True)
        for payload in messages[sent:]:  # the rest flat out, one write each, then close
            conn.sendall(frame(payload))
        conn.close()

    got, coalesced = _receive(stream_and_close, len(messages), marks)
    assert got == messages
    assert coalesced > 0
