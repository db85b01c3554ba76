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
    counters = StatsCounters()
    dispatcher = Dispatcher(counters)
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
            dispatcher.put_messages(batch)
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
    assert counters.snapshot().subscribe_drops == {}


def test_what_a_read_brings_runs_on_the_reader_in_order_with_its_tasks() -> None:
    """Messages queued by the I/O step are run by that worker once the step returns
    (without the inbox while nothing else is queued), in order with the tasks the step
    and other threads submit; a read holding more than a receiver's queue_size still
    drops its oldest, counted.

    The first half of the messages races the other thread's tasks, which the follower
    may run together with messages queued behind them; the second half comes once those
    ran, when only a takeover (the reader slow in callbacks) moves one off the reader.
    """
    counters = StatsCounters()
    total = 3000
    half = total // 2
    sink = Sink("/t", total)  # holds every message however far the runner falls behind
    small = Sink("/small", 2)
    log: list[str] = []
    on_reader: list[bool] = []
    rng = random.Random(11)
    done = threading.Event()
    outside_ran = threading.Event()
    sent = 0
    dispatcher: Dispatcher

    def deliver(payload: bytes, target: Sink = sink) -> None:
        Sink.deliver(target, payload)
        on_reader.append(dispatcher.holds_io)

    sink.deliver = deliver  # type: ignore[method-assign]

    def step() -> bool:
        nonlocal sent
        if sent >= total or (sent >= half and not outside_ran.is_set()):
            return not done.wait(0.001)
        size = min(rng.choice([1, 1, 3, 40]), (half if sent < half else total) - sent)
        dispatcher.put_messages([(sink, str(sent + i).encode()) for i in range(size)])
        sent += size
        if rng.random() < 0.1:
            mark = sent
            dispatcher.submit(lambda: log.append(f"step {mark} {len(sink.got)}"))
        if sent == total:
            dispatcher.put_messages([(small, bytes([i])) for i in range(5)])
        return True

    dispatcher = Dispatcher(counters, step)
    dispatcher.start()
    try:
        for _ in range(20):
            dispatcher.submit(lambda: log.append("outside"))
            threading.Event().wait(0.002)
        first = wait_for(lambda: log.count("outside") == 20 and len(sink.got) == half, 30)
        assert first, (log.count("outside"), len(sink.got))
        takeovers = dispatcher.takeovers
        outside_ran.set()
        ran = wait_for(lambda: len(sink.got) == total and len(small.got) == 2, timeout=30)
        assert ran, (len(sink.got), len(small.got), counters.snapshot().subscribe_drops)
    finally:
        done.set()
        outside_ran.set()
        assert dispatcher.wait_io_done(5)
        dispatcher.stop()
    assert sink.got == [str(i).encode() for i in range(total)]
    marks = [entry.split() for entry in log if entry.startswith("step")]
    assert marks
    assert all(mark == delivered for _, mark, delivered in marks)
    assert log.count("outside") == 20
    assert small.got == [b"\x03", b"\x04"]  # the newest two of one read of five
    assert counters.snapshot().subscribe_drops == {"/small": 3}
    assert all(on_reader[half:]) or dispatcher.takeovers > takeovers
