"""Replay a recording into a ROS graph through a connector, with /clock from its stamps.

Messages go out in recorded order at the recorded pace scaled by `rate` (0: as fast
as possible), converted to the endpoint's serialization when the file's differs.
"""

from __future__ import annotations

import logging
import time
from collections import Counter
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

from rosbags.highlevel import AnyReader

from simbridge.connector import Connector
from simbridge.errors import MessageError, SimError
from simbridge.messages.schema import canonical_of
from simbridge.sim.record.bagfile import bag_kind

__all__ = ["PlayOptions", "PlayStats", "play", "recorded_messages"]

_log = logging.getLogger("simbridge.sim.record")

_LATCHED = frozenset({"/tf_static", "/robot_description"})


@dataclass(frozen=True)
class PlayOptions:
    """How to replay."""

    rate: float = 1.0
    """Speed relative to the recording (2: twice as fast); 0 plays as fast as possible."""
    loop: bool = False
    """Start again at the end (until `stop` says so)."""
    clock: bool = True
    """Publish /clock from the recorded stamps (the recording's own /clock is skipped)."""


@dataclass
class PlayStats:
    """What a replay sent."""

    sent: int = 0
    failed: int = 0
    loops: int = 0
    topics: Counter[str] = field(default_factory=Counter)


def recorded_messages(path: str | Path) -> Iterator[tuple[str, str, int, bytes]]:
    """(topic, msg_type as `pkg/Type`, stamp_ns, payload) in time order."""
    path = Path(path)
    bag_kind(path)
    if not path.is_file():
        raise SimError(f"recording '{path}' does not exist")
    try:
        with AnyReader([path]) as reader:
            for conn, stamp, data in reader.messages():
                yield conn.topic, canonical_of(conn.msgtype), stamp, bytes(data)
    except (OSError, ValueError) as exc:
        raise SimError(f"recording '{path}' cannot be read: {exc}") from exc


def play(
    path: str | Path,
    connector: Connector,
    options: PlayOptions | None = None,
    stop: Callable[[], bool] = lambda: False,
) -> PlayStats:
    """Publish the recording at `path` through `connector` (connected); returns when it
    ends (never with `loop`, until `stop()` is true)."""
    opts = options or PlayOptions()
    if opts.rate < 0:
        raise SimError(f"play rate must be >= 0 (0: as fast as possible), got {opts.rate}")
    src_fmt = "ros1" if bag_kind(path) == "bag" else "cdr"
    stats = PlayStats()
    advertised: dict[str, str] = {}
    registry = connector.registry
    clock_cls, time_cls = registry.msg_class("rosgraph_msgs/Clock"), registry.msg_class("time")
    if opts.clock:
        connector.register_publisher("/clock", "rosgraph_msgs/Clock")
    while True:
        first_ns: int | None = None
        start = time.monotonic()
        for topic, msg_type, stamp_ns, payload in recorded_messages(path):
            if stop():
                return stats
            if first_ns is None:
                first_ns = stamp_ns
            if opts.rate > 0:
                delay = start + (stamp_ns - first_ns) * 1e-9 / opts.rate - time.monotonic()
                if delay > 0:
                    time.sleep(delay)
            if opts.clock:
                if topic == "/clock":
                    continue
                secs, nsecs = divmod(stamp_ns, 1_000_000_000)
                connector.publish("/clock", clock_cls(clock=time_cls(sec=secs, nanosec=nsecs)))
            try:
                data = registry.transcode(payload, msg_type, src_fmt, connector.wire_format)  # type: ignore[arg-type]
            except (MessageError, KeyError) as exc:
                stats.failed += 1
                _log.warning("cannot replay a %s message on %s: %s", msg_type, topic, exc)
                continue
            if advertised.get(topic) != msg_type:
                connector.register_publisher(topic, msg_type, latch=topic in _LATCHED)
                advertised[topic] = msg_type
            connector.publish(topic, data)
            stats.sent += 1
            stats.topics[topic] += 1
        stats.loops += 1
        if not opts.loop or first_ns is None:
            return stats
