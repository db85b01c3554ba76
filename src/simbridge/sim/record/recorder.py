"""Record every message a connector publishes or receives into a bag, off the physics thread.

The connector's tap hands each payload to `Recorder.tap`, which stamps it with the
simulation time and puts it in a bounded queue without ever waiting; a writer thread
converts (ROS 1 binary <-> CDR when the file's format differs from the wire's; an
empty type's CDR to ROS 2's spelling, `simbridge.messages.empty`) and writes. A full
queue drops the message and counts it: recording never slows the physics.
"""

from __future__ import annotations

import logging
import queue
import threading
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from simbridge.connector import Connector
from simbridge.errors import MessageError, SimError
from simbridge.messages import MessageRegistry
from simbridge.sim.record.bagfile import BagFile

__all__ = ["RecordOptions", "RecordStats", "Recorder"]

_log = logging.getLogger("simbridge.sim.record")

_LATCHED = frozenset({"/tf_static", "/robot_description"})


@dataclass(frozen=True)
class RecordOptions:
    """Where and how to record."""

    path: Path
    """`.mcap` (rosbag2 MCAP) or `.bag` (ROS 1 bag); must not exist."""
    buffer: int = 10000
    """Messages waiting for the writer thread; beyond it new messages are dropped."""
    buffer_bytes: int = 256 * 2**20
    """Bytes waiting for the writer thread (camera images are large); beyond, dropped."""


@dataclass
class RecordStats:
    """What a recording holds and what it lost."""

    path: Path
    written: int = 0
    dropped: int = 0
    failed: int = 0
    """Messages that could not be converted to the file's format (logged)."""
    topics: Counter[str] = field(default_factory=Counter)

    def summary(self) -> str:
        """One line for the end of a run."""
        return (
            f"recorded {self.written} messages on {len(self.topics)} topics to {self.path} "
            f"({self.dropped} dropped, {self.failed} unconvertible)"
        )


_Item = tuple[str, str, bytes, int, MessageRegistry, str]
"""(topic, msg_type, payload, stamp_ns, registry, wire_format)"""


class Recorder:
    """Writes what `tap` is shown into a bag; `close()` flushes and returns the stats."""

    def __init__(self, options: RecordOptions, clock: Callable[[], float]) -> None:
        """`clock`: the simulation time in seconds (read on the tapping threads)."""
        if options.buffer < 1 or options.buffer_bytes < 1:
            raise SimError(
                f"record buffer must be >= 1 message and >= 1 byte, got {options.buffer} "
                f"messages, {options.buffer_bytes} bytes"
            )
        self.options = options
        self.clock = clock
        self._file = BagFile(options.path)
        self._queue: queue.Queue[_Item | None] = queue.Queue(options.buffer)
        self._stats = RecordStats(options.path)
        self._dropped = 0
        self._queued_bytes = 0
        self._bytes_lock = threading.Lock()
        self._taps: list[tuple[Connector, Callable[[str, str, bytes, bool], None]]] = []
        self._thread = threading.Thread(target=self._run, name="simbridge-record", daemon=True)
        self._thread.start()

    def attach(self, connector: Connector) -> None:
        """Record every message `connector` publishes or receives from now on."""

        def tap(topic: str, msg_type: str, payload: bytes, outgoing: bool) -> None:
            del outgoing  # both directions are recorded alike
            self.put(topic, msg_type, payload, connector.registry, connector.wire_format)

        connector.add_tap(tap)
        self._taps.append((connector, tap))

    def put(
        self, topic: str, msg_type: str, payload: bytes, registry: MessageRegistry, fmt: str
    ) -> None:
        """Queue one message stamped now (in sim time); never blocks, drops when full."""
        stamp_ns = max(0, round(self.clock() * 1e9))
        size = len(payload)
        with self._bytes_lock:
            if self._queued_bytes + size > self.options.buffer_bytes:
                self._dropped += 1
                return
            try:
                self._queue.put_nowait((topic, msg_type, bytes(payload), stamp_ns, registry, fmt))
            except queue.Full:
                self._dropped += 1
                return
            self._queued_bytes += size

    def progress(self) -> str:
        """A live status line: messages written and dropped so far, and waiting."""
        return (
            f"recording {self.options.path.name}: {self._stats.written:,} messages on "
            f"{len(self._stats.topics)} topics, {self._dropped:,} dropped, "
            f"{self._queue.qsize():,} waiting"
        )

    def topic_counts(self) -> Counter[str]:
        """Messages written so far per topic (a copy)."""
        return Counter(self._stats.topics)

    def _run(self) -> None:
        stats, file = self._stats, self._file
        last_ns = 0
        while True:
            item = self._queue.get()
            if item is None:
                return
            topic, msg_type, payload, stamp_ns, registry, fmt = item
            with self._bytes_lock:
                self._queued_bytes -= len(payload)
            try:
                data = payload
                if fmt != file.wire_format:
                    data = registry.transcode(payload, msg_type, fmt, file.wire_format)  # type: ignore[arg-type]
                elif fmt == "cdr":  # an empty type as Unity spells it: ROS 2's spelling
                    data = registry.codec(msg_type).ros2_cdr(payload)
                conn = file.connection(topic, msg_type, registry, topic in _LATCHED)
                last_ns = max(last_ns, stamp_ns)  # bags want time order
                file.write(conn, last_ns, data)
            except (MessageError, SimError, KeyError, ValueError, OSError) as exc:
                stats.failed += 1
                _log.warning("not recording a %s message on %s: %s", msg_type, topic, exc)
                continue
            stats.written += 1
            stats.topics[topic] += 1

    def close(self) -> RecordStats:
        """Detach, write what is queued, finish the file; the stats (drops logged)."""
        for connector, tap in self._taps:
            connector.remove_tap(tap)
        self._taps.clear()
        if self._thread.is_alive():
            self._queue.put(None)
            self._thread.join()
            self._file.close()
        self._stats.dropped = self._dropped
        if self._dropped:
            _log.warning(
                "recording dropped %d messages (buffer of %d full); raise the buffer "
                "or record fewer topics",
                self._dropped,
                self.options.buffer,
            )
        return self._stats

    def __enter__(self) -> Recorder:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
