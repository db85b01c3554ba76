"""Inbox against a plain reference model (hypothesis): order, per-receiver bounds with
the oldest dropped, tasks never dropped."""

from __future__ import annotations

from typing import Any

from hypothesis import given
from hypothesis import strategies as st

from simbridge.connector.inbox import Inbox


class Sink:
    def __init__(self, topic: str, queue_size: int) -> None:
        self.topic = topic
        self.queue_size = queue_size

    def deliver(self, payload: bytes) -> None:
        raise AssertionError("not called here")


# An operation: ("put", [(receiver index, ...)]) | ("task",) | ("take", n)
ops = st.lists(
    st.one_of(
        st.tuples(st.just("put"), st.lists(st.integers(0, 2), min_size=1, max_size=6)),
        st.tuples(st.just("task")),
        st.tuples(st.just("take"), st.integers(1, 6)),
    ),
    max_size=60,
)


@given(ops, st.lists(st.integers(1, 4), min_size=3, max_size=3))
def test_matches_reference_model(operations: list[tuple[Any, ...]], bounds: list[int]) -> None:
    sinks = [Sink(f"/t{i}", bound) for i, bound in enumerate(bounds)]
    inbox = Inbox()
    model: list[tuple[Sink | None, object]] = []  # live entries in order
    serial = 0
    for op in operations:
        if op[0] == "put":
            entries = []
            expected_drops = []
            for index in op[1]:
                sink = sinks[index]
                payload = str(serial).encode()
                serial += 1
                mine = [i for i, (s, _) in enumerate(model) if s is sink]
                if len(mine) >= sink.queue_size:
                    del model[mine[0]]
                    expected_drops.append(sink)
                model.append((sink, payload))
                entries.append((sink, payload))
            assert inbox.put_messages(entries) == expected_drops
        elif op[0] == "task":

            def task() -> None:
                return None

            model.append((None, task))
            inbox.put_task(task)
        else:
            taken = inbox.take(op[1])
            assert taken == model[: op[1]]
            del model[: op[1]]
        assert len(inbox) == len(model)
        for sink in sinks:
            assert inbox.pending(sink) == sum(1 for s, _ in model if s is sink)
    assert inbox.take(1000) == model
    assert len(inbox) == 0
