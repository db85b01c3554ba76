"""Large message payloads moved from a client's socket to a ROS subscriber's in the kernel.

A camera image published by the sim to one native TCPROS subscriber is the same bytes on
both sockets: the ROS-TCP frame's payload, after the same 4-byte length prefix. Reading
it into the endpoint and writing it out again costs two user-kernel copies, most of the
endpoint's CPU per image. `SpliceRelay` moves it with `os.splice` through a pipe instead
(page references, no copy) while the client's transport is paused. Measured in a
standalone relay of 921 KB messages: 134-141 us of CPU per message against 408-458 us
with the copies.

Only while the subscriber keeps up: one behind by more than MAX_BACKLOG is sent copies,
and when its socket has no room (for SINK_WAIT on a topic that may not drop, where the
client would be pushed back on anyway), the relay reads the rest of the message into the
buffer the decoder had reserved for it and hands the unsent part to the connection,
which queues, holds and pushes back as for any message.
"""

from __future__ import annotations

import asyncio
import contextlib
import fcntl
import logging
import os
import struct
import termios
from collections.abc import Callable
from typing import Protocol

__all__ = [
    "MAX_BACKLOG",
    "PIPE_SIZE",
    "SINK_WAIT",
    "SpliceRelay",
    "SpliceSink",
    "can_splice",
    "unsent",
]

_log = logging.getLogger("simbridge.endpoint")

PIPE_SIZE = 1 << 20
"""Bytes a relay's pipe is asked to hold (Linux's default limit for unprivileged users)."""

SINK_WAIT = 0.01
"""Seconds a relay waits for room in a full socket of a subscriber whose messages may not
be dropped (the client is not read meanwhile) before the rest of the message goes to
the connection's queue instead."""

MAX_BACKLOG = 1 << 20
"""Bytes a subscriber's socket may hold that it has not taken (`unsent`) for a relay to
take the socket. A subscriber that far behind is the slowest process of the stream, and a
rospy subscriber spent a median 10% more CPU reading a spliced image than a copied one
(14 of 17 pairs), so it is sent copies."""

_F_SETPIPE_SZ = 1031
_FLAGS = getattr(os, "SPLICE_F_MOVE", 1) | getattr(os, "SPLICE_F_NONBLOCK", 2)


def can_splice() -> bool:
    """Whether this system has splice(2) (Linux)."""
    return hasattr(os, "splice")


def unsent(fd: int) -> int:
    """Bytes a TCP socket's peer has not yet acknowledged (SIOCOUTQ, which is TIOCOUTQ)."""
    return int(struct.unpack("i", fcntl.ioctl(fd, termios.TIOCOUTQ, bytes(4)))[0])


class SpliceSink(Protocol):
    """Where a relay writes: a subscriber connection that holds its other messages while
    the relay owns its socket."""

    @property
    def splice_wait(self) -> float:
        """Seconds to wait for room in the socket before copying the rest: SINK_WAIT
        where the client would be pushed back on anyway (nothing may be dropped), else
        0 (a client is not held up by a subscriber whose messages may be dropped)."""

    def splice_start(self, lost: Callable[[], None]) -> int | None:
        """The socket to write to, when everything queued before has been sent; until
        `splice_end`, hold other messages, and if the connection goes away meanwhile,
        call `lost()` before its socket closes. None when the socket is busy (nothing
        changes; the message goes the usual way)."""

    def splice_end(self, rest: list[bytes | memoryview] | None, *, moved: bool = True) -> None:
        """The relay is done: queue `rest` (the part of the message it did not move,
        maybe none) and send what was held; None: close the connection (the message was
        cut short on it). `moved` False: the relay could not start after all."""


class SpliceRelay:
    """Moves one message's payload from `source_fd` to a sink, after its length prefix.
    `buffer` (the payload's size, reserved for it) takes the rest when the sink stops
    taking. Driven by the loop's readiness callbacks; `done(ok, buffer_used)` ends it (ok
    False when the source failed: the payload could not be read whole)."""

    def __init__(
        self,
        loop: asyncio.AbstractEventLoop,
        source_fd: int,
        buffer: bytearray,
        sink: SpliceSink,
        *,
        done: Callable[[bool, bool], None],
        moved: Callable[[int], None],
    ) -> None:
        self._loop = loop
        self._source = source_fd
        self._buffer = buffer
        self._sink = sink
        self._done = done
        self._moved = moved
        self._prefix = struct.pack("<I", len(buffer))
        self._left = len(buffer)
        """Payload bytes still in the source socket."""
        self._in_pipe = 0
        self._sent = 0
        """Bytes of the message (prefix and payload) the sink has taken."""
        self._filled = -1
        """Payload bytes in `buffer` once copying took over; -1 while splicing."""
        self._out_fd = -1
        self._reading = False
        self._sink_timer: asyncio.TimerHandle | None = None
        """While waiting for room in the subscriber's socket: when copying takes over."""
        self._sink_lost = False
        self._finished = False
        self._pipe = (-1, -1)

    def start(self) -> bool:
        """Begin, if the sink's socket is free (False: it is not; nothing was done)."""
        fd = self._sink.splice_start(self._lost)
        if fd is None:
            self._finished = True
            return False
        try:
            self._pipe = _pipe()
        except OSError as exc:  # out of descriptors: copy as usual
            _log.warning("cannot splice a large message: %s", exc)
            self._finished = True
            self._sink.splice_end([], moved=False)
            return False
        self._out_fd = fd
        os.write(self._pipe[1], self._prefix)
        self._in_pipe = len(self._prefix)
        self._pump()
        return True

    def cancel(self) -> None:
        """Stop now (the session is closing); a message cut short closes its connection."""
        if not self._finished:
            self._finish(False, notify=False)

    def _lost(self) -> None:
        """The subscriber's connection is closing: the rest of the payload goes nowhere."""
        self._sink_taking()
        self._sink_lost = True
        self._out_fd = _devnull()
        if not self._finished:
            self._loop.call_soon(self._pump)

    def _pump(self) -> None:
        if self._finished or self._out_fd < 0:
            return
        if self._filled >= 0:
            self._copy()
            return
        source, (pipe_r, pipe_w) = self._source, self._pipe
        while True:
            if self._left and self._in_pipe < PIPE_SIZE:
                try:
                    n = os.splice(source, pipe_w, min(self._left, PIPE_SIZE - self._in_pipe),
                                  flags=_FLAGS)  # fmt: skip
                except BlockingIOError:
                    n = -1
                except OSError as exc:
                    _log.warning("a client's large message could not be read: %s", exc)
                    self._finish(False)
                    return
                if n == 0:  # the client left mid-message
                    self._finish(False)
                    return
                if n > 0:
                    self._left -= n
                    self._in_pipe += n
                    self._moved(n)
            if self._in_pipe:
                try:
                    m = os.splice(pipe_r, self._out_fd, self._in_pipe, flags=_FLAGS)
                except BlockingIOError:
                    self._wait_for_sink()
                    return
                except OSError:  # the subscriber left: drain the rest
                    self._lost()
                    return
                self._in_pipe -= m
                self._sent += m
                self._sink_taking()
                continue
            if not self._left:
                self._finish(True)
                return
            break
        self._watch()

    def _wait_for_sink(self) -> None:
        """The subscriber's socket is full: wait for room (for the sink's `splice_wait`
        at most), or copy the rest."""
        wait = self._sink.splice_wait
        if not wait:
            self._start_copy()
        elif self._sink_timer is None:
            self._loop.add_writer(self._out_fd, self._pump)
            self._sink_timer = self._loop.call_later(wait, self._start_copy)

    def _sink_taking(self) -> None:
        if self._sink_timer is not None:
            self._sink_timer.cancel()
            self._sink_timer = None
            self._loop.remove_writer(self._out_fd)

    def _start_copy(self) -> None:
        """The subscriber is behind: take what the pipe holds into the buffer, read the
        rest from the source, and leave the unsent part to the connection's queue."""
        self._sink_taking()
        pipe_r = self._pipe[0]
        head = max(0, len(self._prefix) - self._sent)
        if head:  # part of the length prefix is still in the pipe
            os.read(pipe_r, head)
        filled = self._sent + head - len(self._prefix)
        with memoryview(self._buffer) as view:
            while self._in_pipe > head:
                n = os.readv(pipe_r, [view[filled : filled + self._in_pipe - head]])
                filled += n
                self._in_pipe -= n
        self._in_pipe = 0
        self._filled = filled
        self._copy()

    def _copy(self) -> None:
        size = len(self._buffer)
        with memoryview(self._buffer) as view:
            while self._filled < size:
                try:
                    n = os.readv(self._source, [view[self._filled :]])
                except BlockingIOError:
                    self._watch()
                    return
                except OSError as exc:
                    _log.warning("a client's large message could not be read: %s", exc)
                    self._finish(False)
                    return
                if n == 0:
                    self._finish(False)
                    return
                self._filled += n
                self._left -= n
                self._moved(n)
        self._finish(True)

    def _watch(self) -> None:
        """Wait for more of the payload from the source."""
        if not self._reading:
            self._loop.add_reader(self._source, self._pump)
            self._reading = True

    def _finish(self, ok: bool, *, notify: bool = True) -> None:
        self._finished = True
        self._sink_taking()
        if self._reading:
            self._loop.remove_reader(self._source)
            self._reading = False
        for fd in self._pipe:
            os.close(fd)
        copied = self._filled >= 0
        if not self._sink_lost:
            if ok:
                self._sink.splice_end(self._rest() if copied else [])
            else:
                self._sink.splice_end(None if self._sent else [])
        if notify:
            self._done(ok, copied and ok and not self._sink_lost)

    def _rest(self) -> list[bytes | memoryview]:
        """What the sink has not taken of the message (the buffer holds the payload)."""
        rest: list[bytes | memoryview] = []
        head = len(self._prefix)
        if self._sent < head:
            rest.append(self._prefix[self._sent :])
        rest.append(memoryview(self._buffer)[max(0, self._sent - head) :])
        return rest


def _pipe() -> tuple[int, int]:
    read_fd, write_fd = os.pipe()
    with contextlib.suppress(OSError):  # a smaller pipe only means more wake-ups
        fcntl.fcntl(write_fd, _F_SETPIPE_SZ, PIPE_SIZE)
    os.set_blocking(read_fd, False)
    os.set_blocking(write_fd, False)
    return read_fd, write_fd


_DEVNULL = -1


def _devnull() -> int:
    """A descriptor that takes anything (the rest of a payload nobody wants)."""
    global _DEVNULL
    if _DEVNULL < 0:
        _DEVNULL = os.open(os.devnull, os.O_WRONLY | os.O_CLOEXEC)
    return _DEVNULL
