"""The endpoint's memory budget holds under attack: resident memory of a real endpoint
process stays below the budget plus a fixed overhead (loopback, bounded in time)."""

from __future__ import annotations

import contextlib
import time
from collections.abc import Iterator

import pytest
from benchmarks.attacks import ATTACKS, EndpointProcess, close_all

from simbridge.protocol import (
    CommandReceived,
    ErrorMessage,
    TopicListReply,
    TopicListRequest,
    encode_frame,
)
from tests.endpoint.rawclient import RawClient

MIB = 1024 * 1024
BUDGET_MB = 64
OVERHEAD = 48 * MIB
"""Allowed beyond the budget: interpreter arenas, per-connection scratch buffers and
transport write buffers (bounded by write_high_water per client)."""


@pytest.fixture(scope="module")
def endpoint() -> Iterator[EndpointProcess]:
    with EndpointProcess("--max-memory-mb", str(BUDGET_MB)) as ep:
        time.sleep(0.3)
        yield ep


@pytest.mark.parametrize("name", list(ATTACKS))
def test_resident_memory_stays_within_budget(endpoint: EndpointProcess, name: str) -> None:
    base = endpoint.rss()
    endpoint.reset_peak()
    socks = ATTACKS[name](endpoint.port)
    try:
        time.sleep(0.3)
        peak = endpoint.peak_rss()
        assert endpoint.alive
        assert peak - base < BUDGET_MB * MIB + OVERHEAD, (
            f"{name}: peak {peak / MIB:.0f} MiB from {base / MIB:.0f} MiB"
        )
        probe = RawClient(endpoint.port)  # still serving others
        probe.send(TopicListRequest().encode())
        probe.expect(
            lambda e: isinstance(e, CommandReceived) and isinstance(e.command, TopicListReply)
        )
        probe.close()
    finally:
        close_all(socks)


def test_frame_over_budget_gets_error_naming_budget() -> None:
    with EndpointProcess("--max-memory-mb", "8", "--max-frame-mb", "64") as ep:
        client = RawClient(ep.port)
        big = encode_frame("/big", b"z" * (20 * MIB))
        with contextlib.suppress(OSError):
            client.send(big)
        event = client.expect(
            lambda e: isinstance(e, CommandReceived) and isinstance(e.command, ErrorMessage),
            timeout=10,
        )
        assert "memory budget" in event.command.text
        assert client.closed_by_peer()
