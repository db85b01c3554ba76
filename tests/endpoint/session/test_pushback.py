"""ReadPushback on a real asyncio transport: reading stops while any publisher is behind,
resumes when all caught up, and an episode that outlasts the limit stops holding the
client (until every publisher has caught up once)."""

from __future__ import annotations

import asyncio
import socket

from simbridge.endpoint.session.pushback import (
    PUSHBACK_LIMIT,
    ReadGate,
    ReadPushback,
    pushback_limit,
)

LIMIT = 0.2


async def _transport() -> tuple[asyncio.Transport, socket.socket]:
    ours, theirs = socket.socketpair()
    loop = asyncio.get_running_loop()
    transport, _ = await loop.connect_accepted_socket(asyncio.Protocol, ours)
    assert isinstance(transport, asyncio.Transport)
    return transport, theirs


def test_reading_pauses_while_any_publisher_is_behind() -> None:
    async def scenario() -> list[bool]:
        transport, peer = await _transport()
        pushback = ReadPushback(asyncio.get_running_loop(), limit=60)
        pushback.transport = transport
        seen = [transport.is_reading()]
        pushback.behind("a")
        pushback.behind("b")
        pushback.behind("a")  # again: still one episode
        seen.append(transport.is_reading())
        pushback.caught_up("a")
        seen.append(transport.is_reading())  # b is still behind
        pushback.caught_up("b")
        seen.append(transport.is_reading())
        pushback.caught_up("b")  # unknown now: nothing happens
        pushback.behind("c")
        seen.append(transport.is_reading())
        pushback.close()
        seen.append(transport.is_reading())
        assert pushback.pauses == 2
        transport.close()
        peer.close()
        return seen

    assert asyncio.run(scenario()) == [True, False, False, True, False, True]


def test_an_episode_longer_than_the_limit_reads_again() -> None:
    async def scenario() -> list[bool]:
        loop = asyncio.get_running_loop()
        transport, peer = await _transport()
        pushback = ReadPushback(loop, limit=LIMIT)
        pushback.transport = transport
        pushback.behind("a")
        seen = [transport.is_reading()]
        started = loop.time()
        while not transport.is_reading():
            assert loop.time() - started < 30, "the limit never released the client"
            await asyncio.sleep(0.01)
        assert loop.time() - started >= LIMIT * 0.9
        pushback.behind("b")  # same episode (a is still behind): no new pause
        seen.append(transport.is_reading())
        pushback.caught_up("a")
        pushback.caught_up("b")
        pushback.behind("a")  # a new episode pauses again
        seen.append(transport.is_reading())
        pushback.close()
        transport.close()
        peer.close()
        return seen

    assert asyncio.run(scenario()) == [False, True, False]


def test_the_limit_stays_below_the_client_timeouts() -> None:
    """A client held unread must not be closed as idle or as a slow sender meanwhile."""
    assert pushback_limit(10.0, 10.0) == PUSHBACK_LIMIT
    assert pushback_limit(1.0, 10.0) == 0.5
    assert pushback_limit(0.0, 3.0) == 1.5
    assert pushback_limit(0.0, 0.0) == PUSHBACK_LIMIT  # both off


def test_a_gate_reads_again_only_when_every_holder_let_go() -> None:
    """Back-pressure and a splice pause the same transport: an expired pushback episode
    must not resume reading while a splice still holds it, nor the splice's end while
    pushback does."""

    async def scenario() -> list[bool]:
        transport, peer = await _transport()
        gate = ReadGate()
        gate.transport = transport
        pushback = ReadPushback(asyncio.get_running_loop(), limit=60)
        pushback.transport = gate.holder("pushback")
        gate.pause("splice")
        seen = [transport.is_reading()]
        pushback.behind("a")
        pushback.caught_up("a")
        seen.append(transport.is_reading())  # the splice still holds it
        pushback.behind("a")
        gate.resume("splice")
        seen.append(transport.is_reading())  # pushback still holds it
        gate.resume("splice")  # not a holder any more: nothing happens
        pushback.caught_up("a")
        seen.append(transport.is_reading())
        transport.close()
        peer.close()
        return seen

    assert asyncio.run(scenario()) == [False, False, False, True]
