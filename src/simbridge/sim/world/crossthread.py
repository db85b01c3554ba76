"""What other threads (ROS callbacks, the live view) may ask of a running world: work to
run on the simulation thread, pause and resume, a number of steps while paused, a reset,
a stop. Every public method here is thread-safe; the simulation thread hands over at the
start of each step (`process_posted`) and between steps of `World.run`."""

from __future__ import annotations

import threading
import time
from collections import deque
from collections.abc import Callable

from simbridge.errors import SimError

__all__ = ["CrossThreadControl"]


class CrossThreadControl:
    """The cross-thread side of a `World`: requests queue here and take effect on the
    simulation thread; `reset` is the world's own."""

    def __init__(self) -> None:
        self._posted: deque[Callable[[], None]] = deque()
        self._lock = threading.Lock()
        self._paused = False
        self._pending_steps = 0
        self._reset_requested = False
        self._stop = threading.Event()
        self._running = False
        """Inside `World.run` (between `begin_run` and `end_run`)."""
        self._run_thread: int | None = None
        self._holding = threading.Event()
        """Set while `run` holds time still between steps (see `pause(wait=...)`)."""

    def reset(self) -> None:
        """Back to time 0 (the world's; a requested reset runs it on the simulation thread)."""
        raise NotImplementedError

    # ---- from any thread -------------------------------------------------------------------

    def post(self, fn: Callable[[], None]) -> None:
        """Run `fn()` on the simulation thread before the next step (thread-safe)."""
        self._posted.append(fn)

    def pause(self, wait: float = 0.0) -> bool:
        """Stop advancing time in `run` (thread-safe). With `wait` > 0 and `run` going on
        another thread, wait up to that many seconds for the step in progress to finish,
        so time no longer changes on return; returns whether it is held (True when there
        was nothing to wait for)."""
        self._holding.clear()
        self._paused = True
        if wait <= 0 or not self._running or self._run_thread == threading.get_ident():
            return True
        return self._holding.wait(wait)

    def resume(self) -> None:
        """Continue advancing time in `run` (thread-safe)."""
        self._paused = False
        self._holding.clear()

    @property
    def paused(self) -> bool:
        """Whether `run` is holding time still."""
        return self._paused

    def request_steps(self, count: int) -> None:
        """While paused, let `run` advance exactly `count` more steps (thread-safe)."""
        if count < 0:
            raise SimError(f"step count must be >= 0, got {count}")
        if not self._paused:
            raise SimError("request_steps needs a paused world (call pause() first)")
        with self._lock:
            self._pending_steps += count

    def request_reset(self) -> None:
        """Reset at the start of `run`'s next iteration (thread-safe)."""
        self._reset_requested = True

    def stop(self) -> None:
        """Make `run` return after the current step (thread-safe)."""
        self._stop.set()

    # ---- on the simulation thread ----------------------------------------------------------

    def process_posted(self) -> None:
        """Run what other threads posted, and a requested reset (done by `run` and `step`)."""
        if self._reset_requested:
            self._reset_requested = False
            self.reset()
        while self._posted:  # deque appends and pops are atomic; this is the only consumer
            self._posted.popleft()()

    def take_step(self) -> bool:
        """Whether a step may be taken now: not paused, or paused with a step granted by
        `request_steps` (which this uses up)."""
        if not self._paused:
            return True
        with self._lock:
            if self._pending_steps > 0:
                self._pending_steps -= 1
                return True
        return False

    def hold_while_paused(self, poll: float = 0.002) -> None:
        """For loops that call `step` themselves (not `run`): while paused, wait, running
        posted work, until resumed, or until a step granted by `request_steps` is due
        (which this takes). Returns at once when not paused."""
        while self._paused:
            self.process_posted()
            if self.take_step():
                return
            time.sleep(poll)

    def begin_run(self) -> None:
        """`run` starts on this thread: stop requests from now on end it."""
        self._stop.clear()
        self._run_thread = threading.get_ident()
        self._running = True

    @property
    def running(self) -> bool:
        """Whether `World.run` is going on (on some thread)."""
        return self._running

    @property
    def stop_requested(self) -> bool:
        """Whether `stop` was called since the run began."""
        return self._stop.is_set()

    def holding(self) -> None:
        """`run` holds time still now: release `pause(wait=...)` callers."""
        self._holding.set()

    def end_run(self) -> None:
        """`run` returned: no step follows, so `pause(wait=...)` callers are released."""
        self._running = False
        self._run_thread = None
        self._holding.set()
