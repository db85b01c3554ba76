"""Waiting on a condition in tests: poll it until true, with a bound (never a bare sleep)."""

from __future__ import annotations

import time
from collections.abc import Callable

__all__ = ["wait_for"]


def wait_for(predicate: Callable[[], bool], timeout: float = 60.0) -> bool:
    """Poll `predicate` until true or `timeout` seconds; returns its last value. The
    default is generous: a wait ends when the predicate holds, so only a failing test
    pays for it, and a loaded 2-core CI machine may need several seconds."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(0.005)
    return predicate()
