"""Waiting for a demo's next run while its live view stays live.

Between the runs a view's button queues, the shown world keeps stepping (at the run's
real-time factor, else real time) on a thread of its own, so the page's controls (pause,
joints, dragging objects) act; the stepping stops before the next run starts.
"""

from __future__ import annotations

import queue
import threading

from simbridge.sim.world import World

__all__ = ["next_request"]


def next_request(
    requests: queue.Queue[int],
    stop: threading.Event,
    world: World | None,
    realtime_factor: float,
    name: str,
) -> int | None:
    """The next queued seed (None once `stop` is set), stepping `world` meanwhile (when
    given) at `realtime_factor` (0: real time) on a thread called `name`."""
    idle = threading.Event()
    stepper: threading.Thread | None = None
    if world is not None:
        factor = realtime_factor or 1.0

        def keep_stepping() -> None:
            while not idle.is_set():  # chunks: a stop() before run() starts is not lost
                world.run(0.1, factor)

        stepper = threading.Thread(target=keep_stepping, name=name)
        stepper.start()
    try:
        while not stop.is_set():
            try:
                return requests.get(timeout=0.1)
            except queue.Empty:
                continue
        return None
    finally:
        if world is not None and stepper is not None:
            idle.set()
            world.stop()
            stepper.join(10)
