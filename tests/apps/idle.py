"""Helpers for the demos' view tests: serve on a thread, and check idle stepping."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager

from simbridge.sim.world import World
from tests.waiting import wait_for

__all__ = ["assert_only_the_new_world_steps", "idle_rate", "serving"]


@contextmanager
def serving(serve: Callable[[threading.Event], None], join_s: float) -> Iterator[None]:
    """Run `serve(stop)` on a thread for the block; then stop it and check it ended."""
    stop = threading.Event()
    server = threading.Thread(target=serve, args=(stop,))
    server.start()
    try:
        yield
    finally:
        stop.set()
        server.join(join_s)
    assert not server.is_alive()


def idle_rate(world: World) -> float:
    """Simulated seconds per wall second of `world` over 1.5 s, after 0.3 s to settle."""
    time.sleep(0.3)
    sim0, wall0 = world.time, time.perf_counter()
    time.sleep(1.5)
    return (world.time - sim0) / (time.perf_counter() - wall0)


def assert_only_the_new_world_steps(first: World, second: World) -> None:
    """After a new run: the previous world is stopped and the new one steps while idle."""
    assert second is not first
    held, sim0 = first.time, second.time
    assert wait_for(lambda: second.time > sim0, timeout=10), "the new world steps while idle"
    time.sleep(0.5)
    assert first.time == held, "the previous world no longer steps"
