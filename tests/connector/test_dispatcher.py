"""The dispatch thread runs every queued payload and task once, in order, however the
reader's hand-offs interleave with its own draining (short batches, bursts, tasks)."""

from __future__ import annotations

import random
import threading

from simbridge.connector.dispatcher import Dispatcher
from simbridge.connector.stats import StatsCounters
from tests.waiting import wait_for


class Sink:
    def __init__(self, topic: str, queue_size: int) -> None:
        self.topic = topic
        self.queue_size = queue_size
        self.got: list[bytes] = []

    def deliver(self, payload: bytes) -> None:
        self.got.append(payload)


def test_every_hand_off_is_run_in_order() -> None:
    dispatcher = Dispatcher(StatsCounters())
    dispatcher.start()
    total = 20_000
    sink = Sink("/t", total)
    tasks: list[tuple[int, int]] = []

    def task_after(mark: int) -> None:
        dispatcher.submit(lambda: tasks.append((mark, len(sink.got))))

    total = 20_000
    rng = random.Random(7)
    try:
        sent = 0
        while sent < total:
            size = min(rng.choice([1, 1, 2, 5, 300]), total - sent)
            batch = [(sink, str(sent + i).encode()) for i in range(size)]
            assert dispatcher.put_messages(batch) == []
            sent += size
            if rng.random() < 0.05:
                task_after(sent)
            if rng.random() < 0.01:
                threading.Event().wait(0.001)  # let the dispatcher run dry now and then
        assert wait_for(lambda: len(sink.got) == total, timeout=30)
    finally:
        dispatcher.stop()
    assert sink.got == [str(i).encode() for i in range(total)]
    assert tasks
    assert all(mark == delivered for mark, delivered in tasks)  # ran in queue order
