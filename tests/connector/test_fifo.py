"""BoundedFifo against a plain reference model (hypothesis)."""

from __future__ import annotations

import threading
import time
from typing import Any

from hypothesis import given
from hypothesis import strategies as st

from simbridge.connector.fifo import BoundedFifo, Signal

# An operation: ("put", key, bound) | ("control",) | ("take", n)
ops = st.lists(
    st.one_of(
        st.tuples(st.just("put"), st.sampled_from("abc"), st.integers(1, 4)),
        st.tuples(st.just("control")),
        st.tuples(st.just("take"), st.integers(1, 6)),
    ),
    max_size=60,
)


@given(ops)
def test_matches_reference_model(operations: list[tuple[Any, ...]]) -> None:
    fifo: BoundedFifo[str, int] = BoundedFifo()
    model: list[tuple[str | None, int]] = []  # global order of live items
    drops = {"a": 0, "b": 0, "c": 0}
    counted = {"a": 0, "b": 0, "c": 0}
    for serial, op in enumerate(operations):
        if op[0] == "put":
            _, key, bound = op
            mine = [i for i, (k, _) in enumerate(model) if k == key]
            if len(mine) >= bound:
                del model[mine[0]]
                drops[key] += 1
            model.append((key, serial))
            if fifo.put(key, serial, bound):
                counted[key] += 1
        elif op[0] == "control":
            model.append((None, serial))
            fifo.put_control(serial)
        else:
            taken = fifo.take(op[1], 1 << 30)
            assert taken == model[: op[1]]
            del model[: op[1]]
        assert len(fifo) == len(model)
        for key in "abc":
            assert fifo.pending(key) == sum(1 for k, _ in model if k == key)
    assert counted == drops
    assert fifo.take(1000, 1 << 30) == model


def test_take_stops_at_size_budget_but_returns_at_least_one() -> None:
    fifo: BoundedFifo[str, bytes] = BoundedFifo()
    for i in range(5):
        fifo.put("img", bytes([i]), 10, size=1000)
    assert [item for _, item in fifo.take(100, 1)] == [b"\x00"]
    assert [item for _, item in fifo.take(100, 2500)] == [b"\x01", b"\x02", b"\x03"]


def test_front_control_and_discard() -> None:
    fifo: BoundedFifo[str, str] = BoundedFifo()
    fifo.put("t", "m1", 5)
    fifo.put_control("old-command")
    fifo.put("t", "m2", 5)
    removed = fifo.discard_control(lambda _item: False)
    assert removed == ["old-command"]
    fifo.put_control_front(["hello", "register"])
    assert fifo.take(10, 1 << 30) == [(None, "hello"), (None, "register"), ("t", "m1"), ("t", "m2")]


def test_put_many_reports_drops_per_entry() -> None:
    fifo: BoundedFifo[str, int] = BoundedFifo()
    dropped = fifo.put_many([("a", 1, 2), ("a", 2, 2), ("a", 3, 2), ("b", 4, 1), ("b", 5, 1)])
    assert dropped == ["a", "b"]
    assert fifo.take(10, 1 << 30) == [("a", 2), ("a", 3), ("b", 5)]
    assert fifo.ready.is_set()


def test_signal_behaves_like_an_event() -> None:
    """Signal: set, clear, wait with and without a timeout, many waiters, racing setters."""
    signal = Signal()
    assert not signal.is_set()
    start = time.monotonic()
    assert signal.wait(0.05) is False
    assert time.monotonic() - start >= 0.04
    signal.set()
    signal.set()  # a second set is a no-op, not a second release
    assert signal.is_set()
    assert signal.wait()
    assert signal.wait(0)
    signal.clear()
    signal.clear()
    assert not signal.is_set()
    assert signal.wait(0) is False

    woken: list[int] = []
    waiters = [
        threading.Thread(target=lambda i=i: woken.append(i) if signal.wait(5) else None)
        for i in range(4)
    ]
    for thread in waiters:
        thread.start()
    time.sleep(0.05)
    assert woken == []
    setters = [threading.Thread(target=signal.set) for _ in range(8)]
    for thread in setters:
        thread.start()
    for thread in [*setters, *waiters]:
        thread.join(5)
    assert sorted(woken) == [0, 1, 2, 3]
    assert signal.is_set()
    signal.clear()
    assert not signal.wait(0.01)


def test_signal_hand_off_loses_no_wake() -> None:
    """A consumer that clears, drains and waits (the dispatcher's loop) sees every item
    a producer queues, however the two interleave."""
    fifo: BoundedFifo[str, int] = BoundedFifo()
    got: list[int] = []
    total = 20_000

    def consume() -> None:
        while len(got) < total:
            if not fifo.ready.wait(5):
                return
            fifo.ready.clear()
            while batch := fifo.take(7, 1 << 30):
                got.extend(item for _, item in batch)

    consumer = threading.Thread(target=consume)
    consumer.start()
    for i in range(total):
        fifo.put("k", i, total)
    consumer.join(10)
    assert got == list(range(total))
