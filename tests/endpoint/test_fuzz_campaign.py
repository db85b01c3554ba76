"""A fuzz campaign of hostile frames against an endpoint process: it never dies, stays
within its memory budget, answers hostile commands with `__error`s and keeps serving.

The default run does a bounded campaign; the long one (`-m slow`) runs for minutes.
"""

from __future__ import annotations

import json
import random
import socket
import struct
import time

import pytest
from benchmarks.attacks import EndpointProcess

from simbridge.protocol import (
    CommandReceived,
    ErrorMessage,
    ProtocolConnection,
    TopicListReply,
    TopicListRequest,
    encode_frame,
)

COMMANDS = [
    "__publish",
    "__subscribe",
    "__ros_service",
    "__unity_service",
    "__remove_subscriber",
    "__request",
    "__response",
    "__topic_list",
    "__stats",
    "__service_error",
]
BUDGET_MB = 64


def _name(rng: random.Random) -> str:
    return rng.choice(
        [
            "/a",
            "/ok_topic",
            "/\ud800",
            "/" + "x" * rng.randrange(200, 5000),
            "a b",
            "",
            "/a//b",
            "std_msgs/String",
            "nope/Nothing",
            "x/" + "Y" * rng.randrange(1, 3000),
        ]
    )


def _value(rng: random.Random, depth: int = 0) -> object:
    kind = rng.randrange(8)
    if kind == 0 and depth < 3:
        return [_value(rng, depth + 1) for _ in range(rng.randrange(3))]
    if kind == 1 and depth < 3:
        return {_name(rng): _value(rng, depth + 1) for _ in range(rng.randrange(3))}
    if kind == 2:
        return rng.choice([-1, 0, 10, 2**31, 2**63, -(2**70)])
    if kind == 3:
        return _name(rng)
    return rng.choice([None, True, 1.5, "text"])


def _hostile_frame(rng: random.Random) -> bytes:
    command = rng.choice(COMMANDS)
    kind = rng.randrange(6)
    if kind == 0:
        return encode_frame(command, b"[" * rng.randrange(1000, 200_000))
    if kind == 1:
        digits = b"9" * rng.randrange(20, 10_000)
        return encode_frame(command, b'{"queue_size": ' + digits + b', "srv_id": ' + digits + b"}")
    if kind == 2:
        body = {"topic": _name(rng), "message_name": _name(rng), "queue_size": _value(rng)}
        return encode_frame(command, json.dumps(body).encode())
    if kind == 3:
        body = {_name(rng): _value(rng) for _ in range(rng.randrange(4))}
        return encode_frame(command, json.dumps(body).encode())
    if kind == 4:
        return ProtocolConnection.service_request(rng.randrange(2**31), _destination(rng), b"x")
    return encode_frame(_destination(rng), rng.randbytes(rng.randrange(64)))


def _destination(rng: random.Random) -> str:
    """A name for a frame's destination (UTF-8 encodable: the frame must stay in sync)."""
    name = _name(rng)
    return name if name and "\ud800" not in name and not name.startswith("__") else "/m"


def _campaign(connections: int, seconds: float, seed: int) -> dict[str, int]:
    rng = random.Random(seed)
    counts = {"connections": 0, "frames": 0, "answered": 0, "errors": 0}
    with EndpointProcess("--max-memory-mb", str(BUDGET_MB), "--max-clients", "64") as ep:
        time.sleep(0.3)
        base = ep.rss()
        deadline = time.monotonic() + seconds
        while counts["connections"] < connections and time.monotonic() < deadline:
            frames = [_hostile_frame(rng) for _ in range(rng.randrange(1, 8))]
            with socket.create_connection(("127.0.0.1", ep.port), timeout=10) as sock:
                sock.sendall(b"".join(frames) + TopicListRequest().encode())
                proto = ProtocolConnection("client")
                got_list = False
                errors = 0
                while not got_list:
                    data = sock.recv(1 << 20)
                    if not data:
                        break
                    for event in proto.receive_data(data):
                        if isinstance(event, CommandReceived):
                            errors += isinstance(event.command, ErrorMessage)
                            got_list |= isinstance(event.command, TopicListReply)
                # Every frame here is well framed: the stream stays in sync and is answered.
                assert got_list, f"connection {counts['connections']} closed without a reply"
            counts["connections"] += 1
            counts["frames"] += len(frames)
            counts["answered"] += 1
            counts["errors"] += errors
            assert ep.alive
        assert ep.peak_rss() - base < (BUDGET_MB + 48) * 2**20
    return counts


def test_bounded_fuzz_campaign() -> None:
    counts = _campaign(connections=60, seconds=30, seed=15)
    assert counts["answered"] == counts["connections"] >= 20
    assert counts["errors"] >= counts["connections"] // 2


@pytest.mark.slow
def test_long_fuzz_campaign() -> None:
    counts = _campaign(connections=20_000, seconds=600, seed=1515)
    assert counts["answered"] == counts["connections"] > 1000


def test_frame_builders_are_well_framed() -> None:
    rng = random.Random(3)
    for _ in range(200):
        frame = _hostile_frame(rng)
        dlen = struct.unpack_from("<I", frame)[0]
        # A service request is two frames back to back; each is length-consistent.
        assert dlen <= len(frame)
