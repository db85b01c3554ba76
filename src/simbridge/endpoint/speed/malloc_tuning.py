"""Keep large message buffers in the heap instead of mapping fresh pages for each one.

glibc serves an allocation above its mmap threshold (128 KiB at first, raised on the
fly only while nothing is trimmed) with a new mapping and unmaps it on free; the next
camera image then page-faults through a megabyte of new, zeroed pages in every copy
(rcl's take buffer, the Python bytes, the Fast DDS payload). Raising the threshold and
the trim threshold keeps such buffers in the heap and reuses them: about 300 page
faults fewer per 640x480 rgb8 image relayed by the ROS 2 backend. Memory freed stays
with the process (up to the trim threshold), which the endpoint's own budget bounds.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import logging
import sys

__all__ = ["MMAP_THRESHOLD", "TRIM_THRESHOLD", "keep_large_buffers"]

_log = logging.getLogger(__name__)

MMAP_THRESHOLD = 32 * 1024 * 1024
"""Allocations below this come from the heap (glibc's largest allowed value)."""
TRIM_THRESHOLD = 256 * 1024 * 1024
"""Free memory at the top of a heap kept for reuse instead of given back."""

_M_TRIM_THRESHOLD = -1
_M_MMAP_THRESHOLD = -3


def keep_large_buffers() -> bool:
    """Set glibc's thresholds for this process; False (and nothing changed) without glibc."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        mallopt = libc.mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes = (ctypes.c_int, ctypes.c_int)
    mallopt.restype = ctypes.c_int
    done = bool(mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD)) and bool(
        mallopt(_M_TRIM_THRESHOLD, TRIM_THRESHOLD)
    )
    _log.debug("malloc thresholds %s", "set" if done else "not accepted")
    return done
