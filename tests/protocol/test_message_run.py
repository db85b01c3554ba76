"""`ProtocolConnection.message_runs`, the shortcut for a read of plain messages that
repeat the last frame's header, yields exactly the events `buffer_updated` would,
whatever the frames (commands, service headers and their frames, keepalives) and cuts."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from simbridge.protocol import (
    KEEPALIVE,
    Event,
    MessageReceived,
    ProtocolConnection,
    Publish,
    encode_frame,
)

FRAMES = st.one_of(
    st.just(encode_frame("/a", b"ping")),
    st.just(encode_frame("/a", b"ping")),
    st.builds(lambda p: encode_frame("/a", p), st.binary(max_size=6)),
    st.just(encode_frame("/b", b"ping")),
    st.just(KEEPALIVE),
    st.just(encode_frame("", b"x")),
    st.just(Publish("/a", "std_msgs/String").encode()),
    st.just(encode_frame("__publish", b"{bad")),
    st.just(ProtocolConnection.service_request(3, "/a", b"ping")),
    st.just(ProtocolConnection.service_response(4, "/a", b"ping")),
    st.just(b"\xff\xff\xff\xff"),  # a destination over the limit: fatal
)


@given(
    st.lists(FRAMES, max_size=30),
    st.lists(st.integers(min_value=1, max_value=120), min_size=1, max_size=6),
)
def test_message_runs_give_the_events_buffer_updated_gives(
    frames: list[bytes], cuts: list[int]
) -> None:
    """The frames, cut into reads of the given sizes, go to two connections: one tries the
    shortcut first (as the session does), one uses `buffer_updated` alone; events, closing
    and the decoder's partial frame agree after every read."""
    data = b"".join(frames)
    fast, plain = ProtocolConnection("endpoint"), ProtocolConnection("endpoint")
    pos = i = 0
    while pos < len(data) and not plain.closed:
        chunk = data[pos : pos + cuts[i % len(cuts)]]
        targets = fast.get_buffer(), plain.get_buffer()
        n = min(len(targets[0]), len(targets[1]), len(chunk))
        for target in targets:
            target[:n] = chunk[:n]
            target.release()
        expected = plain.buffer_updated(n)
        burst = fast.message_runs(n)
        got: list[Event]
        if burst is not None:
            got = [MessageReceived(burst[0], payload) for payload in burst[1]]
        else:
            got = fast.buffer_updated(n)
        assert got == expected
        assert fast.closed == plain.closed
        assert fast.decoder.partial == plain.decoder.partial
        pos += n
        i += 1


def test_a_service_frame_is_never_taken_for_a_message() -> None:
    """Even when its header repeats a message's, the frame after `__request` is the
    request's payload (the general path's ServiceRequestReceived)."""
    conn = ProtocolConnection("endpoint")
    ping = encode_frame("/a", b"ping")
    request = ProtocolConnection.service_request(3, "/a", b"ping")
    events = []
    for chunk in (ping, request[: len(request) - len(ping)], request[-len(ping) :]):
        target = conn.get_buffer()
        target[: len(chunk)] = chunk
        target.release()
        assert conn.message_runs(len(chunk)) is None
        events += conn.buffer_updated(len(chunk))
    assert [type(e).__name__ for e in events] == ["MessageReceived", "ServiceRequestReceived"]


def test_a_burst_cut_inside_a_message_is_taken_and_the_rest_waits() -> None:
    conn = ProtocolConnection("endpoint")
    ping = encode_frame("/a", b"ping")
    data = ping * 5
    events = []
    for chunk in (
        data[: len(ping)],
        data[len(ping) : 3 * len(ping) + 3],
        data[3 * len(ping) + 3 :],
    ):
        target = conn.get_buffer()
        target[: len(chunk)] = chunk
        target.release()
        burst = conn.message_runs(len(chunk))
        if burst is None:
            events += conn.buffer_updated(len(chunk))
        else:
            events += [MessageReceived(burst[0], payload) for payload in burst[1]]
    assert events == [MessageReceived("/a", b"ping")] * 5
    assert not conn.decoder.partial


def test_a_burst_ending_in_another_whole_frame_is_left_to_the_general_path() -> None:
    """A read whose rest after the repeated messages is a whole frame of its own (here a
    keepalive, or a shorter message) is not a burst: that frame must not wait for the
    next read."""
    ping = encode_frame("/a", b"ping")
    for tail in (KEEPALIVE, encode_frame("/a", b"p")):
        conn = ProtocolConnection("endpoint")
        for chunk in (ping, ping * 3 + tail):
            target = conn.get_buffer()
            target[: len(chunk)] = chunk
            target.release()
            assert conn.message_runs(len(chunk)) is None
            conn.buffer_updated(len(chunk))
        assert not conn.decoder.partial
