"""Writes deferred to the end of the read that caused them (endpoint/speed/deferred.py)."""

from __future__ import annotations

import asyncio
import logging

import pytest

from simbridge.endpoint.speed.deferred import DeferredWrites, deferred_writes


def test_inside_a_read_writes_wait_for_its_release_not_the_loop() -> None:
    async def main() -> list[str]:
        writes = DeferredWrites(asyncio.get_running_loop())
        log: list[str] = []
        writes.hold()
        writes.defer(lambda: log.append("a"))
        writes.hold()  # a nested input (an in-process delivery during the read)
        writes.defer(lambda: log.append("b"))
        writes.release()
        log.append("inner released")
        writes.release()
        log.append("outer released")
        await asyncio.sleep(0)
        return log

    assert asyncio.run(main()) == ["inner released", "a", "b", "outer released"]


def test_outside_a_read_writes_leave_at_the_end_of_the_iteration_once() -> None:
    async def main() -> tuple[list[str], list[str]]:
        writes = DeferredWrites(asyncio.get_running_loop())
        log: list[str] = []
        writes.defer(lambda: log.append("x"))
        writes.defer(lambda: log.append("y"))
        before = list(log)
        await asyncio.sleep(0)
        return before, log

    assert asyncio.run(main()) == ([], ["x", "y"])


def test_a_flush_that_defers_more_and_a_failing_flush_do_not_stop_the_rest(
    caplog: pytest.LogCaptureFixture,
) -> None:
    async def main() -> list[str]:
        writes = DeferredWrites(asyncio.get_running_loop())
        log: list[str] = []

        def fail() -> None:
            raise OSError("gone")

        writes.hold()
        writes.defer(lambda: writes.defer(lambda: log.append("second")))
        writes.defer(fail)
        writes.defer(lambda: log.append("first"))
        writes.release()
        return log

    with caplog.at_level(logging.ERROR, logger="simbridge.endpoint"):
        assert asyncio.run(main()) == ["first", "second"]
    assert "a deferred write failed" in caplog.text


def test_one_instance_per_loop() -> None:
    async def main() -> bool:
        loop = asyncio.get_running_loop()
        return deferred_writes(loop) is deferred_writes(loop)

    first = asyncio.new_event_loop()
    try:
        assert first.run_until_complete(main())
    finally:
        first.close()
