"""Writing a batch of frames to an asyncio transport with as few copies as the kernel allows."""

from __future__ import annotations

import asyncio
import os
from collections.abc import Sequence

__all__ = ["WRITE_ALONE", "write_chunks"]

_IOV_MAX = 1024
"""Most buffers one writev takes (Linux IOV_MAX)."""
WRITE_ALONE = 64 * 1024
"""Chunks at least this long go to the transport as they are; smaller ones are joined."""


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
            sent = os.writev(fd, chunks[:_IOV_MAX])
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
        transport.write(rest)
    if small:
        transport.write(b"".join(small) if len(small) > 1 else small[0])
