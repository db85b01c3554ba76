"""Large messages spliced from a client's socket to a single native TCPROS subscriber,
against a real roscore: every byte arrives in order whether the subscriber keeps up,
lags, leaves mid-message or shares the topic with another client; a client that leaves
mid-message cuts only that subscriber's connection; a subscriber behind and --no-splice
get copies."""

from __future__ import annotations

import contextlib
import socket
import time

import pytest
from tests.endpoint.rawclient import RawClient
from tests.ros1support import RosMaster, require_ros, ros_string

from simbridge.endpoint import EndpointOptions, EndpointThread
from simbridge.endpoint.speed.splice import unsent
from simbridge.protocol import (
    Publish,
    encode_frame,
)
from simbridge.protocol.tcpros import TcprosDecoder

require_ros(module_level=True)

from tests.endpoint.backends.ros1.test_native import (  # noqa: E402
    send_in_background,
    subscriber_header,
    tcpros_address,
    topic_list,
)

from simbridge.endpoint.backends.ros1 import Ros1Backend  # noqa: E402

pytestmark = [
    pytest.mark.ros1,
    pytest.mark.timeout(120),
    pytest.mark.filterwarnings("ignore:notifyAll:DeprecationWarning"),
]


def _messages(count: int, size: int = 900_000, tag: str = "m") -> list[bytes]:
    return [ros_string(f"{tag}{i:07d}" + chr(97 + i % 26) * size) for i in range(count)]


def _publisher(port: int, topic: str) -> RawClient:
    client = RawClient(port)
    client.send(Publish(topic, "std_msgs/String", queue_size=0).encode())
    topic_list(client)  # every earlier frame was handled
    return client


def _subscribe(topic: str, rcvbuf: int = 0) -> tuple[socket.socket, TcprosDecoder]:
    host, port = tcpros_address(topic)
    sock = socket.socket()
    if rcvbuf:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, rcvbuf)
    sock.connect((host, port))
    sock.sendall(subscriber_header(topic))
    decoder = TcprosDecoder(4 << 20)
    while decoder.header is None:
        data = sock.recv(65536)
        assert data, "the server closed without a header"
        decoder.feed(data)
    return sock, decoder


def _receive(
    sock: socket.socket, decoder: TcprosDecoder, count: int, pause: float = 0.0
) -> list[bytes]:
    got: list[bytes] = []
    deadline = time.monotonic() + 60
    while len(got) < count:
        assert time.monotonic() < deadline, f"got {len(got)} of {count}"
        data = sock.recv(1 << 20)
        assert data, "the endpoint closed the connection"
        got += decoder.feed(data)
        if pause:
            time.sleep(pause)
    return got


def _stream(
    options: EndpointOptions, topic: str, messages: list[bytes]
) -> tuple[list[bytes], dict[str, int]]:
    """`messages` from a client to one subscriber that keeps up (each is sent once the one
    before it arrived): what it got, and the counters."""
    with EndpointThread(options, Ros1Backend()) as ep:
        client = _publisher(ep.port, topic)
        sock, decoder = _subscribe(topic)
        got: list[bytes] = []
        for message in messages:
            client.send(encode_frame(topic, message))
            got += _receive(sock, decoder, 1)
        counters: dict[str, int] = client.stats()["server"]["backend_counters"]
        sock.close()
        client.close()
    return got, counters


def _stream_to_slow_reader(
    topic: str, messages: list[bytes], pause: float, rcvbuf: int = 0
) -> tuple[list[bytes], dict[str, int]]:
    """`messages` sent at once by a client to one subscriber that sleeps `pause` after
    each read: what it got, and the counters."""
    with EndpointThread(EndpointOptions(port=0, idle_timeout=0), Ros1Backend()) as ep:
        client = _publisher(ep.port, topic)
        sock, decoder = _subscribe(topic, rcvbuf=rcvbuf)
        sender = send_in_background(client, [encode_frame(topic, m) for m in messages])
        got = _receive(sock, decoder, len(messages), pause=pause)
        sender.join(10)
        counters: dict[str, int] = client.stats()["server"]["backend_counters"]
        sock.close()
        client.close()
    return got, counters


@pytest.mark.parametrize("splice", [True, False])
def test_large_messages_reach_a_prompt_subscriber_whole_spliced_or_not(
    master: RosMaster, splice: bool
) -> None:
    """A stream of 900 KB messages to one subscriber that reads at once: all arrive whole
    and in order; they go by splice unless the endpoint was told not to."""
    topic = "/sb/splice/prompt"
    messages = _messages(20)
    options = EndpointOptions(port=0, idle_timeout=0, splice=splice)
    got, counters = _stream(options, topic, messages)
    assert got == messages
    if splice:
        # the first one arrives with its header in one read (copied); the rest are spliced
        assert counters["ros1_spliced_messages"] >= len(messages) // 2, counters
    else:
        assert counters["ros1_spliced_messages"] == 0


def test_a_subscriber_behind_the_stream_is_sent_copies(master: RosMaster) -> None:
    """A subscriber reading slower than the client sends: once its socket holds more than
    MAX_BACKLOG unread, messages are copied (spliced pages cost a reader behind more), and
    every one arrives whole and in order. Splicing each regardless moved 9-11 of 12."""
    messages = _messages(12)
    got, counters = _stream_to_slow_reader("/sb/splice/behind", messages, pause=0.01)
    assert got == messages
    assert counters["ros1_spliced_messages"] < len(messages) // 2, counters


def test_unsent_counts_what_the_peer_has_not_taken() -> None:
    """`unsent` is the bytes a socket's peer has not acknowledged: those beyond a full
    receive buffer while it does not read, none once it has read everything."""
    with socket.create_server(("127.0.0.1", 0)) as server:
        sender = socket.create_connection(server.getsockname())
        receiver, _ = server.accept()
        with sender, receiver:
            receiver.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 64 * 1024)
            sender.setblocking(False)
            sent = 0
            with contextlib.suppress(BlockingIOError):
                while sent < 8 << 20:
                    sent += sender.send(b"x" * 65536)
            time.sleep(0.05)
            waiting = unsent(sender.fileno())
            assert 0 < waiting < sent
            taken = 0
            while taken < sent:
                taken += len(receiver.recv(1 << 20))
            deadline = time.monotonic() + 5
            while unsent(sender.fileno()) and time.monotonic() < deadline:
                time.sleep(0.01)
            assert unsent(sender.fileno()) == 0


def test_a_lagging_subscriber_gets_every_byte_when_copying_takes_over(master: RosMaster) -> None:
    """A subscriber with a small receive buffer that reads slowly: a splice that finds
    its socket full hands the rest of the message to the connection's queue; nothing is
    lost, reordered or cut."""
    messages = _messages(8, size=2_500_000)  # more than a pipe holds: copying reads the rest
    got, counters = _stream_to_slow_reader(
        "/sb/splice/lagging", messages, pause=0.003, rcvbuf=64 * 1024
    )
    assert got == messages
    assert counters["ros1_dropped_to_ros"] == 0


def test_two_clients_on_one_topic_never_interleave_inside_a_message(master: RosMaster) -> None:
    """One client streams large messages while another sends small ones on the same
    topic: the subscriber sees each message whole (the small ones wait while a large one
    is spliced), each client's in its own order."""
    topic = "/sb/splice/shared"
    large = _messages(12, tag="L")
    small = [ros_string(f"S{i:07d}") for i in range(200)]
    options = EndpointOptions(port=0, idle_timeout=0)
    with EndpointThread(options, Ros1Backend()) as ep:
        big_client = _publisher(ep.port, topic)
        small_client = _publisher(ep.port, topic)
        sock, decoder = _subscribe(topic)
        senders = [
            send_in_background(big_client, [encode_frame(topic, m) for m in large]),
            send_in_background(small_client, [encode_frame(topic, m) for m in small]),
        ]
        got = _receive(sock, decoder, len(large) + len(small))
        for sender in senders:
            sender.join(10)
        sock.close()
        big_client.close()
        small_client.close()
    assert [m for m in got if m[4:5] == b"L"] == large
    assert [m for m in got if m[4:5] == b"S"] == small


def test_a_subscriber_leaving_mid_stream_costs_the_client_nothing(master: RosMaster) -> None:
    """The subscriber closes while large messages stream to it: the client stays
    connected and answered, and a new subscriber gets the later messages whole."""
    topic = "/sb/splice/leaving"
    options = EndpointOptions(port=0, idle_timeout=0)
    with EndpointThread(options, Ros1Backend()) as ep:
        client = _publisher(ep.port, topic)
        sock, decoder = _subscribe(topic, rcvbuf=64 * 1024)
        first = _messages(10, tag="a")
        sender = send_in_background(client, [encode_frame(topic, m) for m in first])
        _receive(sock, decoder, 2)
        sock.close()  # mid-stream, most likely mid-message
        sender.join(30)
        client.sock.settimeout(5)
        assert client.stats()["server"]["backend_counters"]["ros1_spliced_messages"] >= 1
        again, again_decoder = _subscribe(topic)
        later = _messages(5, tag="b")
        sender = send_in_background(client, [encode_frame(topic, m) for m in later])
        got = _receive(again, again_decoder, len(later))
        sender.join(10)
        assert not client.closed_by_peer(timeout=0.2)
        again.close()
        client.close()
    assert got == later


def test_a_client_leaving_mid_message_cuts_only_that_message(master: RosMaster) -> None:
    """A client sends half a large message and disconnects: the subscriber's connection
    is closed (it holds a cut message; a ROS subscriber reconnects), the endpoint lives
    on, and a new client's messages reach a new subscriber whole."""
    topic = "/sb/splice/cut"
    options = EndpointOptions(port=0, idle_timeout=0)
    with EndpointThread(options, Ros1Backend()) as ep:
        client = _publisher(ep.port, topic)
        sock, decoder = _subscribe(topic)
        whole = _messages(2, tag="w")
        frames = [encode_frame(topic, m) for m in whole]
        cut = encode_frame(topic, _messages(1, tag="c")[0])
        client.sock.sendall(b"".join(frames) + cut[: len(cut) // 2])
        got = _receive(sock, decoder, 2)
        time.sleep(0.3)
        client.close()
        sock.settimeout(10)
        rest = b""
        while chunk := sock.recv(1 << 20):  # the endpoint closes the cut connection
            rest += chunk
        sock.close()
        assert len(rest) < len(cut)
        other = _publisher(ep.port, topic)
        again, again_decoder = _subscribe(topic)
        later = _messages(3, tag="n")
        sender = send_in_background(other, [encode_frame(topic, m) for m in later])
        got_later = _receive(again, again_decoder, len(later))
        sender.join(10)
        again.close()
        other.close()
    assert got == whole
    assert got_later == later


def test_a_client_stalling_mid_message_is_closed_as_a_slow_sender(master: RosMaster) -> None:
    """A client that stops halfway through a spliced message is closed once the frame
    timeout passes (the bytes a splice moves count as received, so only a real stall
    trips it), and the subscriber's connection, holding a cut message, with it."""
    topic = "/sb/splice/stall"
    options = EndpointOptions(port=0, idle_timeout=0, frame_timeout=1.0)
    with EndpointThread(options, Ros1Backend()) as ep:
        client = _publisher(ep.port, topic)
        sock, decoder = _subscribe(topic)
        first, stalled = _messages(2, tag="t")
        cut = encode_frame(topic, stalled)
        client.sock.sendall(encode_frame(topic, first) + cut[: len(cut) // 2])
        got = _receive(sock, decoder, 1)
        assert client.closed_by_peer(timeout=10)
        sock.settimeout(10)
        while sock.recv(1 << 20):  # the endpoint closes the cut connection too
            pass
        sock.close()
    assert got == [first]


def test_a_stalled_subscriber_of_a_topic_that_may_drop_never_holds_the_client(
    master: RosMaster,
) -> None:
    """queue_size 1: the client is read on while its subscriber takes nothing (a request
    after 20 large messages is answered at once), the messages past the queue are dropped
    and counted, and those the subscriber gets are whole, in order, ending with the last."""
    topic = "/sb/splice/may_drop"
    messages = _messages(20, tag="d")
    options = EndpointOptions(port=0, idle_timeout=0)
    with EndpointThread(options, Ros1Backend()) as ep:
        client = RawClient(ep.port)
        client.send(Publish(topic, "std_msgs/String", queue_size=1).encode())
        topic_list(client)
        sock, decoder = _subscribe(topic, rcvbuf=64 * 1024)
        frames = [encode_frame(topic, m) for m in messages]
        sender = send_in_background(client, frames)
        sender.join(20)
        assert not sender.is_alive(), "the client was not read while its subscriber stalled"
        counters = client.stats()["server"]["backend_counters"]  # answered while stalled
        sock.settimeout(2.0)
        got: list[bytes] = []
        try:
            while True:
                data = sock.recv(1 << 20)
                if not data:
                    break
                got += decoder.feed(data)
        except TimeoutError:
            pass
        sock.close()
        client.close()
    assert counters["ros1_dropped_to_ros"] >= 1
    assert got
    assert got[-1] == messages[-1]
    positions = [messages.index(m) for m in got]  # each one whole, as sent
    assert positions == sorted(positions)


def test_without_a_pipe_large_messages_are_copied_as_usual(
    master: RosMaster, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A relay that cannot get a pipe (out of descriptors) gives the connection back at
    once: every message arrives whole, none counted as spliced, and the client is read on."""
    from simbridge.endpoint.speed import splice

    def no_pipe() -> tuple[int, int]:
        raise OSError(24, "Too many open files")

    monkeypatch.setattr(splice, "_pipe", no_pipe)
    topic = "/sb/splice/no_pipe"
    messages = _messages(6, tag="p")
    options = EndpointOptions(port=0, idle_timeout=0)
    got, counters = _stream(options, topic, messages)
    assert got == messages
    assert counters["ros1_spliced_messages"] == 0
