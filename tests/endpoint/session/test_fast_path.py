"""The session's shortcut for a read of messages repeating the last frame's header
(`ProtocolConnection.message_runs`: one, or a burst) behaves exactly as the general path:
same messages published, same replies and errors, same counters, however the bytes are
cut into reads."""

from __future__ import annotations

import asyncio
from typing import Any
from unittest import mock

from hypothesis import given, settings
from hypothesis import strategies as st

from simbridge.endpoint import EndpointOptions
from simbridge.endpoint.backends.base import BackendPublisher
from simbridge.endpoint.backends.local import LocalBus
from simbridge.endpoint.budget import MemoryBudget
from simbridge.endpoint.session import ClientSession
from simbridge.endpoint.typecheck import RegistryTypeCheck
from simbridge.messages import registry_for
from simbridge.protocol import (
    KEEPALIVE,
    ProtocolConnection,
    Publish,
    RemovePublisher,
    encode_frame,
)


class _Transport(asyncio.Transport):
    """Collects what the session writes (no socket: every write goes through `write`)."""

    def __init__(self) -> None:
        super().__init__()
        self.out = bytearray()
        self.closed = False

    def get_extra_info(self, name: str, default: Any = None) -> Any:
        return default

    def set_write_buffer_limits(self, high: int | None = None, low: int | None = None) -> None:
        pass

    def get_write_buffer_size(self) -> int:
        return 0

    def write(self, data: bytes | bytearray | memoryview) -> None:
        self.out += data

    def is_closing(self) -> bool:
        return self.closed

    def close(self) -> None:
        self.closed = True

    def pause_reading(self) -> None:
        pass

    def resume_reading(self) -> None:
        pass


TYPE = "std_msgs/String"


def _string(text: bytes) -> bytes:
    return len(text).to_bytes(4, "little") + text


FRAMES = st.one_of(
    # mostly messages on the registered topic at one size, so headers repeat
    st.just(encode_frame("/a", _string(b"ping"))),
    st.just(encode_frame("/a", _string(b"ping"))),
    st.just(encode_frame("/a", _string(b"ping"))),
    st.builds(lambda t: encode_frame("/a", _string(t)), st.binary(max_size=8)),
    st.just(encode_frame("/unregistered", _string(b"ping"))),
    st.just(KEEPALIVE),
    st.just(Publish("/a", TYPE).encode()),
    st.just(RemovePublisher("/a").encode()),
    st.just(encode_frame("", b"junk")),
    st.just(encode_frame("__publish", b"{not json")),
    # a service frame after its header repeats the header of a message before it
    st.just(ProtocolConnection.service_request(7, "/a", _string(b"ping"))),
    st.just(ProtocolConnection.service_response(8, "/a", _string(b"ping"))),
)


class _Host:
    """What the session needs of a server, without a listening socket."""

    def __init__(self, loop: asyncio.AbstractEventLoop) -> None:
        self.options = EndpointOptions(port=0)
        self.backend = LocalBus()
        self.types = RegistryTypeCheck(registry_for(self.backend.protocol))
        self.budget = MemoryBudget(self.options.max_memory, self.options.client_share)
        self.loop = loop
        self.sessions: set[ClientSession] = set()

    def admit(self, session: ClientSession) -> bool:
        self.sessions.add(session)
        return True

    def forget(self, session: ClientSession) -> None:
        self.sessions.discard(session)

    def drain(self, peer: str, publishers: list[tuple[str, BackendPublisher]]) -> None:
        for _, publisher in publishers:
            publisher.close()

    def stats(self) -> dict[str, Any]:
        return {"clients": len(self.sessions)}


async def _run(data: bytes, cuts: list[int]) -> tuple[Any, ...]:
    server = _Host(asyncio.get_running_loop())
    await server.backend.start()
    published: list[bytes] = []
    server.backend.subscribe("/a", TYPE, published.append)
    session = ClientSession(server)
    transport = _Transport()
    session.connection_made(transport)
    pos = i = 0
    while pos < len(data) and not transport.closed:
        target = session.get_buffer(-1)
        n = min(len(target), cuts[i % len(cuts)], len(data) - pos)
        target[:n] = data[pos : pos + n]
        session.buffer_updated(n)
        pos += n
        i += 1
    stats = session.stats.as_dict()
    state = (session.proven, session.frame_started == 0.0, session.proto.closed)
    session.connection_lost(None)
    return published, bytes(transport.out), stats, state, transport.closed


def _both(data: bytes, cuts: list[int]) -> tuple[tuple[Any, ...], tuple[Any, ...], int]:
    """The session's results with the shortcut, then without it; and how often it was taken."""
    taken = 0
    real_runs = ProtocolConnection.message_runs

    def counting_runs(self: ProtocolConnection, nbytes: int) -> tuple[str, list[bytes]] | None:
        nonlocal taken
        runs = real_runs(self, nbytes)
        taken += runs is not None
        return runs

    with mock.patch.object(ProtocolConnection, "message_runs", counting_runs):
        fast = asyncio.run(_run(data, cuts))
    with mock.patch.object(ProtocolConnection, "message_runs", return_value=None):
        general = asyncio.run(_run(data, cuts))
    return fast, general, taken


@settings(max_examples=150, deadline=None)
@given(
    st.lists(FRAMES, max_size=25),
    st.lists(st.integers(min_value=1, max_value=200), min_size=1, max_size=6),
    st.booleans(),
)
def test_shortcut_and_general_path_agree_however_cut(
    frames: list[bytes], cuts: list[int], register: bool
) -> None:
    head = Publish("/a", TYPE).encode() if register else b""
    data = head + b"".join(frames)
    fast, general, _ = _both(data, cuts)
    assert fast == general


def test_one_message_per_read_takes_the_shortcut_and_matches() -> None:
    ping = encode_frame("/a", _string(b"ping"))
    registration = Publish("/a", TYPE).encode()
    # every ping arrives in a read of its own: all but the first repeat the header before
    cuts = [len(registration)] + [len(ping)] * 20
    fast, general, taken = _both(registration + ping * 20, cuts)
    assert fast == general
    assert taken == 19
    published, _, stats, state, closed = fast
    assert published == [_string(b"ping")] * 20
    assert stats["frames_in"] == 21
    assert state == (True, True, False)
    assert not closed


def test_shortcut_on_an_unregistered_topic_answers_as_the_general_path() -> None:
    ping = encode_frame("/unregistered", _string(b"ping"))
    fast, general, taken = _both(ping * 3, [len(ping)])
    assert taken == 2
    assert fast == general
    _, out, stats, _, _ = fast
    assert b"not registered for publishing" in out
    assert stats["frames_in"] == 3
    assert stats["errors_sent"] == 1


def test_a_burst_per_read_takes_the_burst_shortcut_and_matches() -> None:
    """Reads of several pings each, cut inside a ping too (its header, or its header and
    part of its payload, waits for the next read), publish every ping in order."""
    ping = encode_frame("/a", _string(b"ping"))
    registration = Publish("/a", TYPE).encode()
    cuts = [len(registration) + len(ping), 3 * len(ping) + 5, 2 * len(ping) + 15, len(ping)]
    fast, general, taken = _both(registration + ping * 60, cuts)
    assert fast == general
    assert taken > 10
    published, _, stats, state, closed = fast
    assert published == [_string(b"ping")] * 60
    assert stats["frames_in"] == 61
    assert state == (True, True, False)
    assert not closed
