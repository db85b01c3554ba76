"""ROS 2 subscriptions taken on the endpoint's event loop, woken by a waiting thread.

rclpy's executor takes a message on its own thread before it calls a subscription's
callback, so relayed messages crossed from that thread to the event loop, and the two
Python threads took turns at the GIL: while the loop framed and wrote a burst, nothing
was taken. Samples then wait in Fast DDS's reader history, and each new one costs the
DDS thread a scan of every sample waiting (its StatefulReader looks each new sample up
from the start of the history): a burst of thousands of Twists cost it 3 to 4 times its
usual time per message, and took the CPU the relay needed.

Here a thread of its own only waits (an rcl wait set on the subscriptions and a guard
condition, the GIL released) and tells the loop which subscriptions have messages;
the loop takes them (a bounded round each) and hands the round to the session at once
(small messages framed and written together), so nothing queues between threads and the
DDS history stays short. The thread waits again once the loop has taken its round. A
round that a bound ended (a burst) goes on in the loop's next iteration, after whatever
else is ready there, for up to _CONTINUED_ROUNDS rounds before the thread waits again:
a burst of Twists went through the thread every 256 messages, and each trip (building a
wait set, waking the loop from another thread, the two threads taking turns at the GIL)
left the samples waiting in the DDS history meanwhile, which makes every new one cost
the DDS thread more.
Subscriptions join a callback group the executor never runs, so the executor leaves
them alone.
"""

from __future__ import annotations

import asyncio
import logging
import threading
from contextlib import ExitStack
from typing import Any, Protocol

from rclpy.callback_groups import CallbackGroup
from rclpy.exceptions import InvalidHandle
from rclpy.guard_condition import GuardCondition
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy

from simbridge.endpoint.backends.loop_calls import call_soon_from_thread
from simbridge.endpoint.speed.deferred import deferred_writes

__all__ = ["LoopTakes", "Takeable"]

_log = logging.getLogger(__name__)

_CONTINUED_ROUNDS = 8
"""Rounds taken one after another on the loop (a call_soon each, so the loop serves its
other callbacks and I/O between them) before waiting on the thread again, which also
notices subscriptions that were not ready before."""


class Takeable(Protocol):
    """A subscription whose messages the loop takes."""

    @property
    def handle(self) -> Any:
        """The rclpy subscription's handle (for the wait set)."""

    def take_round(self) -> bool:
        """On the loop: take and deliver a bounded round of messages; True when the
        bound ended it (more may be waiting)."""


class _NeverExecuted(CallbackGroup):  # type: ignore[misc]  # rclpy has no stubs here
    """The group of the loop's subscriptions: the executor neither waits on nor runs them."""

    def can_execute(self, entity: Any) -> bool:
        return False

    def beginning_execution(self, entity: Any) -> bool:
        return False

    def ending_execution(self, entity: Any) -> None:
        return None


class LoopTakes:
    """Waits for the subscriptions' messages on a thread; the event loop takes them."""

    def __init__(self, context: Any, loop: asyncio.AbstractEventLoop) -> None:
        self.callback_group: CallbackGroup = _NeverExecuted()
        self._context = context
        self._loop = loop
        self._writes = deferred_writes(loop)
        self._guard = GuardCondition(None, None, context=context)
        self._watched: set[Takeable] = set()
        self._taken = threading.Event()
        self._stopped = False
        self._continued = 0
        """Rounds taken on the loop since the thread last waited."""
        self._thread = threading.Thread(target=self._run, name="simbridge-rclpy-wait", daemon=True)
        self._thread.start()

    def add(self, takeable: Takeable) -> None:
        """Start waiting on `takeable` (from the loop)."""
        self._watched.add(takeable)
        self._guard.trigger()

    def remove(self, takeable: Takeable) -> None:
        """Stop waiting on `takeable` (from the loop), so its handle can be destroyed."""
        self._watched.discard(takeable)
        self._guard.trigger()

    async def close(self) -> None:
        """Stop the thread (before the context shuts down)."""
        self._stopped = True
        self._taken.set()
        self._guard.trigger()
        await asyncio.to_thread(self._thread.join, 5.0)
        self._guard.destroy()

    def _run(self) -> None:
        while not self._stopped:
            try:
                ready = self._wait(list(self._watched))
            except Exception:
                if self._stopped or not self._context.ok():
                    return
                _log.exception("waiting for ROS 2 messages failed")
                self._taken.wait(0.1)
                continue
            if ready and not self._stopped:
                self._taken.clear()
                if not call_soon_from_thread(self._loop, self._take, ready):
                    return
                self._taken.wait()

    def _wait(self, watched: list[Takeable]) -> list[Takeable]:
        """Block until a watched subscription has a message or the guard fires."""
        with ExitStack() as held:
            by_pointer: dict[int, Takeable] = {}
            for takeable in watched:
                handle = takeable.handle
                try:
                    held.enter_context(handle)
                except InvalidHandle:  # destroyed meanwhile
                    continue
                by_pointer[handle.pointer] = takeable
            held.enter_context(self._guard.handle)
            held.enter_context(self._context.handle)
            wait_set = _rclpy.WaitSet(len(by_pointer), 1, 0, 0, 0, 0, self._context.handle)
            wait_set.clear_entities()
            for takeable in by_pointer.values():
                wait_set.add_subscription(takeable.handle)
            wait_set.add_guard_condition(self._guard.handle)
            wait_set.wait(-1)
            ready = wait_set.get_ready_entities("subscription")
        return [by_pointer[pointer] for pointer in ready if pointer in by_pointer]

    def _take(self, ready: list[Takeable]) -> None:
        """On the loop: a round from each ready subscription still watched; what they write
        leaves at the end. Subscriptions with more waiting get another round in the loop's
        next iteration, up to _CONTINUED_ROUNDS; otherwise the thread waits again."""
        writes = self._writes
        writes.hold()
        busy: list[Takeable] = []
        try:
            for takeable in ready:
                if takeable in self._watched and takeable.take_round():
                    busy.append(takeable)
        finally:
            writes.release()
            if busy and self._continued < _CONTINUED_ROUNDS and not self._stopped:
                self._continued += 1
                self._loop.call_soon(self._take, busy)
            else:
                self._continued = 0
                self._taken.set()
