"""Handing a call from a backend's own thread to the endpoint's event loop."""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from typing import Any

__all__ = ["call_soon_from_thread"]


def call_soon_from_thread(
    loop: asyncio.AbstractEventLoop, fn: Callable[..., None], *args: Any
) -> bool:
    """Schedule `fn(*args)` on `loop` from another thread; False when the loop is closed
    (the endpoint is going away, so there is nobody left to tell)."""
    try:
        loop.call_soon_threadsafe(fn, *args)
    except RuntimeError:
        return False
    return True
