"""Two worker threads that take turns reading the socket and running callbacks.

Handing every received batch from a reader thread to a dispatch thread costs a thread
wake-up and a GIL hand-off (~35 us on a loaded machine): the largest part of the
connector's share of a round trip. Here the thread that read the data runs the callbacks
itself (leader/follower). The worker holding the I/O role runs bounded I/O steps
(connect, one read, a slice of back-off) and, when a step queued work and no callback
is running, runs it at once, waking nothing. The other worker follows:

- when the reader's callbacks have run for `STALL_S`, it takes the I/O role over, so a
  slow or blocked callback never stalls reading, service responses, call timeouts or
  reconnection for longer than that;
- a callback that calls a blocking connector method (`Connector.call`, `topic_list`,
  `close`) hands it the I/O role at once (`yield_io`): the reply needs a reader;
- it runs work queued from other threads while no callback is running.

The messages one read brings are held by the reader until its I/O step returns and, when
no other work is queued or running, run from there without passing through the inbox
(its lock, its per-receiver counts and a take: a few microseconds per read at tens of
thousands of messages a second); otherwise, or when a read holds more messages than a
receiver's `queue_size`, they are queued as any other (bounded, drops counted).

One callback runs at a time, in queue order, whichever thread runs it; exceptions in
callbacks are logged and counted, not fatal.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Sequence

from simbridge.connector.fifo import Signal
from simbridge.connector.inbox import Inbox, Receiver, Task
from simbridge.connector.stats import StatsCounters

__all__ = ["STALL_S", "Dispatcher", "IoStep", "Receiver", "Task"]

_log = logging.getLogger("simbridge.connector")

_BATCH = 256
STALL_S = 0.01
"""How long the reader may run callbacks before the other worker takes reading over."""
_IDLE_POLLS = 50
"""Polls (of `STALL_S`) without a callback run on the reader after which the follower
sleeps until woken (an idle connector costs no wake-ups); the next run then wakes it."""

_LEAD, _RUN, _WAIT = "lead", "run", "wait"
"""What a worker does next: I/O steps, queued work, or wait."""

IoStep = Callable[[], bool]
"""One bounded piece of I/O work; False once there is none left for good (closed)."""


class Dispatcher:
    """Runs queued work in order, one item at a time, on whichever of two worker threads
    is free: payloads for receivers (bounded per receiver, oldest dropped) and tasks;
    and, with an `io_step`, passes the I/O role between the two (see the module doc)."""

    def __init__(self, counters: StatsCounters, io_step: IoStep | None = None) -> None:
        self.inbox = Inbox()
        self._counters = counters
        self._io_step = io_step
        self._lock = threading.Lock()
        self._signals = (Signal(), Signal())
        """One per worker (each clears only its own, so no wake-up is lost), both set
        after any change a waiting worker may have to act on."""
        self._io: int | None = None
        """Ident of the worker holding the I/O role."""
        self._io_done = threading.Event()
        if io_step is None:
            self._io_done.set()
        self._runner: int | None = None
        """Ident of the worker running callbacks."""
        self._since = 0.0
        """When the I/O holder began its current run of callbacks."""
        self._runs = 0
        """Runs of callbacks by the I/O holder so far (the follower's sign of activity)."""
        self._asleep = False
        """The follower waits without polling; the next run on the I/O holder wakes it."""
        self._external = False
        """Work was queued from outside the I/O role: a free worker must run it (what the
        I/O holder queues, it runs itself after its step)."""
        self._stop = False
        self._held: list[tuple[Receiver, bytes]] = []
        """Messages the I/O holder's current step read, run or queued after the step (only
        the thread running I/O steps touches it, and one thread at a time does)."""
        self.takeovers = 0
        """Times the follower took reading over from a worker stuck in callbacks."""
        self._threads = [
            threading.Thread(
                target=self._work, args=(signal,), name=f"simbridge-connector-{i}", daemon=True
            )
            for i, signal in enumerate(self._signals, 1)
        ]

    def start(self) -> None:
        """Start the workers."""
        for thread in self._threads:
            thread.start()

    def stop(self) -> None:
        """End the workers once their current task returns (queued tasks are dropped)."""
        self._stop = True
        self._wake()
        me = threading.current_thread()
        for thread in self._threads:
            if thread.is_alive() and thread is not me:
                thread.join(timeout=5.0)

    def wait_io_done(self, timeout: float) -> bool:
        """Wait until the I/O steps ended for good (the connector closed)."""
        return self._io_done.wait(timeout)

    @property
    def holds_io(self) -> bool:
        """True when called from the worker holding the I/O role."""
        return self._io == threading.get_ident()

    @property
    def on_thread(self) -> bool:
        """True when called from a callback (a worker running queued work)."""
        return self._runner == threading.get_ident()

    def submit(self, task: Task) -> None:
        """Run `task` after everything queued before it."""
        if self._held and self._io == threading.get_ident():
            self._queue_held()  # messages the running step read came first
        self.inbox.put_task(task)
        self._queued()

    def put_messages(self, entries: Sequence[tuple[Receiver, bytes]]) -> None:
        """Queue payloads for their receivers: bounded by each one's `queue_size` (the
        oldest dropped and counted). From the I/O holder's step they are held, and run
        once the step returns (`_lead`)."""
        if self._io == threading.get_ident():
            self._held += entries
            return
        self._queue(entries)
        self._queued()

    def _queue(self, entries: Sequence[tuple[Receiver, bytes]]) -> None:
        """Put messages into the inbox (bounded; drops counted) without waking anyone."""
        for receiver in self.inbox.put_messages(entries):
            self._counters.subscribe_dropped(receiver.topic)

    def _queue_held(self) -> None:
        """Move the held messages into the inbox, ahead of what comes next."""
        held, self._held = self._held, []
        self._queue(held)

    def _queued(self) -> None:
        """Work was queued: the I/O holder runs it after its step; from any other thread,
        wake a worker when none is running callbacks."""
        if self._io == threading.get_ident():
            return
        with self._lock:
            self._external = True
            wake = self._runner is None
        if wake:
            self._wake()

    def yield_io(self) -> None:
        """About to block in a callback: hand the I/O role to the other worker if this
        thread holds it, so what the caller waits for can be read."""
        me = threading.get_ident()
        if self._io != me:
            return
        with self._lock:
            if self._io == me and self._runner == me:
                self._io = None
                self._asleep = False
                self._wake()

    def _wake(self) -> None:
        for signal in self._signals:
            signal.set()

    def _work(self, signal: Signal) -> None:
        me = threading.get_ident()
        seen_runs = -1
        idle_polls = 0
        while True:
            signal.clear()
            role = _WAIT
            timeout: float | None = STALL_S
            with self._lock:
                if self._stop:
                    return
                if self._io is None and not self._io_done.is_set():
                    self._io = me
                    role = _LEAD
                elif (
                    self._runner is None
                    and self.inbox.count
                    and (self._external or self._io is None)
                ):
                    self._runner = me
                    self._external = False
                    role = _RUN
                elif self._io is not None and self._runner == self._io:
                    waited = time.monotonic() - self._since
                    if waited >= STALL_S:
                        self._io = me  # the reader is stuck in callbacks: take over
                        self.takeovers += 1
                        role = _LEAD
                    else:
                        timeout = STALL_S - waited
                    idle_polls = 0
                elif self._runs != seen_runs:
                    seen_runs = self._runs
                    idle_polls = 0
                else:
                    idle_polls += 1
                    if idle_polls >= _IDLE_POLLS or self._io_done.is_set():
                        self._asleep = True
                        timeout = None
            if role is _LEAD:
                self._lead(me)
            elif role is _RUN:
                self._run_callbacks()
            else:
                signal.wait(timeout)
                if timeout is None:
                    idle_polls = 0

    def _lead(self, me: int) -> None:
        """Run I/O steps while this thread holds the role, until they end (`stop` does not
        cut them short: the connection is torn down once closing); run what they queue."""
        step = self._io_step
        assert step is not None
        inbox = self.inbox
        while True:
            try:
                alive = step()
            except Exception:
                _log.exception("connector I/O failed; it stops")
                alive = False
            if not alive:
                if self._held:
                    self._queue_held()
                with self._lock:
                    self._io = None
                    self._io_done.set()
                    self._wake()
                return
            held = self._held
            if held:
                self._held = []
                size = len(held)
                if size > 1 and any(r.queue_size < size for r, _ in held):
                    self._queue(held)  # more than a receiver may hold: the inbox drops
                    held = []
            elif not inbox.count:
                continue
            with self._lock:  # (a runner finishing decides under the lock, so ask there)
                if held and (self._runner is not None or inbox.count):
                    self._queue(held)  # behind what is queued or running
                    held = []
                if self._runner is not None or not (held or inbox.count):
                    continue
                self._runner = me
                self._external = False
                self._since = time.monotonic()
                self._runs += 1
                if self._asleep:
                    self._asleep = False
                    self._wake()
            if held:
                self._run_held(held)
            self._run_callbacks()
            if self._io != me:
                return  # taken over or handed on while the callbacks ran

    def _run_held(self, held: list[tuple[Receiver, bytes]]) -> None:
        """Run what the last step read, in order (this thread is the runner)."""
        counters = self._counters
        for receiver, payload in held:
            if self._stop:
                return
            try:
                receiver.deliver(payload)
            except Exception:
                counters.callback_failed()
                _log.exception("callback raised; the connector keeps running")

    def _run_callbacks(self) -> None:
        """Run queued work in order until the queue is empty (this thread is the runner)."""
        inbox = self.inbox
        counters = self._counters
        while not self._stop:
            # (nothing queued, as after a read run straight from `_held`: no take)
            batch = inbox.take(_BATCH) if inbox.count else []
            for receiver, item in batch:
                if self._stop:
                    return
                try:
                    if receiver is not None:
                        receiver.deliver(item)  # type: ignore[arg-type]
                    else:
                        item()  # type: ignore[operator]
                except Exception:
                    counters.callback_failed()
                    _log.exception("callback raised; the connector keeps running")
            if len(batch) < _BATCH:
                with self._lock:
                    if not inbox.count:
                        self._runner = None
                        self._external = False
                        return
