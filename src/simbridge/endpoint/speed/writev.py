"""Scatter-gather writes to a socket with as few copies as the kernel allows.

`write_chunks` writes through an asyncio transport (what the kernel does not take at
once goes to the transport's buffer, small pieces joined, a view of lent memory copied).
`SocketWriter` owns a non-blocking socket's writes instead: what the kernel does not take
is kept as views of the caller's buffers and written from them when the socket has room,
so a camera image crosses user space no more than once however slowly its reader reads.
"""

from __future__ import annotations

import asyncio
import itertools
import os
from collections import deque
from collections.abc import Callable, Sequence

__all__ = ["WRITE_ALONE", "SocketWriter", "write_chunks"]

_IOV_MAX = 1024
"""Most buffers one writev takes (Linux IOV_MAX)."""
WRITE_ALONE = 64 * 1024
"""Chunks at least this long go to the transport as they are; smaller ones are joined."""

Chunk = bytes | bytearray | memoryview


def write_chunks(
    transport: asyncio.WriteTransport, fd: int, chunks: Sequence[bytes | memoryview]
) -> None:
    """Send `chunks` in order: one scatter-gather syscall on `fd` while the transport has
    nothing queued (no chunk copied or joined; asyncio 3.11 would copy a partly sent buffer
    and join writelines), then what the kernel did not take through the transport, small
    chunks joined and large ones as they are (joining would copy them again)."""
    sent = 0
    if fd >= 0 and not transport.get_write_buffer_size():
        try:
            sent = os.writev(fd, chunks if len(chunks) <= _IOV_MAX else chunks[:_IOV_MAX])
        except (BlockingIOError, InterruptedError):
            sent = 0
        except OSError:
            sent = 0  # the transport sees the error on its own write and reports it
    small: list[bytes | memoryview] = []
    for chunk in chunks:
        if sent >= len(chunk):
            sent -= len(chunk)
            continue
        rest: bytes | memoryview = memoryview(chunk)[sent:] if sent else chunk
        sent = 0
        if len(rest) < WRITE_ALONE:
            small.append(rest)
            continue
        if small:
            transport.write(b"".join(small))
            small = []
        transport.write(_owned(rest))
    if small:
        transport.write(b"".join(small) if len(small) > 1 else _owned(small[0]))


def _owned(chunk: bytes | memoryview) -> bytes | memoryview:
    """`chunk`, or a copy of it when it is a view of memory its owner may reuse (a payload
    a backend lends for one call): asyncio's transports queue what they are given without
    copying it since Python 3.12 (3.11's copied)."""
    if isinstance(chunk, memoryview) and not isinstance(chunk.obj, bytes):
        return bytes(chunk)
    return chunk


class SocketWriter:
    """Writes chunks to a non-blocking socket in order, straight from the chunks.

    While nothing is queued a write is one `writev`. What the kernel does not take is
    queued as the chunks themselves (a partly sent one as a view of its rest: nothing is
    copied or joined) and written with `writev` whenever the socket has room, on the
    event loop. `on_drained` is called when the queue empties; `on_error` once, with the
    error, when a write fails (nothing is written after that). Callers must not modify
    a chunk once written.
    """

    __slots__ = ("_fd", "_loop", "_on_drained", "_on_error", "_queue", "closed", "queued")

    def __init__(
        self,
        loop: asyncio.AbstractEventLoop,
        fd: int,
        on_drained: Callable[[], None],
        on_error: Callable[[OSError], None],
    ) -> None:
        self._loop = loop
        self._fd = fd
        self._on_drained = on_drained
        self._on_error = on_error
        self._queue: deque[Chunk] = deque()
        self.queued = 0
        """Bytes written but not yet taken by the kernel."""
        self.closed = False

    def write(self, chunks: Sequence[Chunk]) -> None:
        """Send `chunks` after everything written before them."""
        if self.closed or not chunks:
            return
        queue = self._queue
        if queue:
            for chunk in chunks:
                queue.append(chunk)
                self.queued += len(chunk)
            return
        sent = self._writev(chunks if len(chunks) <= _IOV_MAX else chunks[:_IOV_MAX])
        if sent < 0:
            return
        for chunk in chunks:
            size = len(chunk)
            if sent >= size:
                sent -= size
                continue
            queue.append(memoryview(chunk)[sent:] if sent else chunk)
            self.queued += size - sent
            sent = 0
        if queue:
            self._loop.add_writer(self._fd, self._writable)

    @property
    def chunks(self) -> int:
        """Chunks written but not yet (wholly) taken by the kernel."""
        return len(self._queue)

    def close(self) -> None:
        """Stop writing and forget what is queued (the socket is the caller's to close)."""
        if not self.closed:
            self.closed = True
            if self._queue:
                self._loop.remove_writer(self._fd)
            self._queue.clear()
            self.queued = 0

    def _writable(self) -> None:
        queue = self._queue
        sent = self._writev(list(itertools.islice(queue, _IOV_MAX)))
        if sent < 0:
            return
        self.queued -= sent
        while sent:
            size = len(queue[0])
            if sent < size:
                queue[0] = memoryview(queue[0])[sent:]
                break
            queue.popleft()
            sent -= size
        if not queue:
            self._loop.remove_writer(self._fd)
            self._on_drained()

    def _writev(self, chunks: Sequence[Chunk]) -> int:
        """Bytes the kernel took (0 when it had no room), or -1 after an error."""
        try:
            return os.writev(self._fd, chunks)
        except (BlockingIOError, InterruptedError):
            return 0
        except OSError as exc:
            self.close()
            self._on_error(exc)
            return -1
