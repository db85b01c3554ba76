"""The dispatch thread: runs user callbacks and service handlers off the socket reader.

A slow callback therefore delays only later callbacks, never keepalives or service
responses; exceptions in callbacks are logged and counted, not fatal.
"""

from __future__ import annotations

import logging
import threading

from simbridge.connector.inbox import Inbox, Receiver, Task
from simbridge.connector.stats import StatsCounters

__all__ = ["Dispatcher", "Receiver", "Task"]

_log = logging.getLogger("simbridge.connector")

_BATCH = 256


class Dispatcher:
    """Runs queued work in order on one thread: payloads for receivers (bounded per
    receiver, oldest dropped) and plain tasks."""

    def __init__(self, counters: StatsCounters) -> None:
        self.inbox = Inbox()
        self._counters = counters
        self._stop = False
        self._thread = threading.Thread(
            target=self._run, name="simbridge-connector-dispatch", daemon=True
        )

    def start(self) -> None:
        """Start the thread."""
        self._thread.start()

    def stop(self) -> None:
        """End the thread once its current task returns (queued tasks are dropped)."""
        self._stop = True
        self.inbox.ready.set()
        if self._thread.is_alive() and threading.current_thread() is not self._thread:
            self._thread.join(timeout=5.0)

    @property
    def on_thread(self) -> bool:
        """True when called from the dispatch thread itself."""
        return threading.current_thread() is self._thread

    def submit(self, task: Task) -> None:
        """Run `task` after everything queued before it."""
        self.inbox.put_task(task)

    def _run(self) -> None:
        inbox = self.inbox
        while not self._stop:
            inbox.ready.wait()
            inbox.ready.clear()
            while not self._stop:
                # Anything queued after clear() sets `ready` again, so a short batch
                # needs no second take() to find the queue empty.
                batch = inbox.take(_BATCH)
                for receiver, item in batch:
                    if self._stop:
                        return
                    try:
                        if receiver is not None:
                            receiver.deliver(item)  # type: ignore[arg-type]
                        else:
                            item()  # type: ignore[operator]
                    except Exception:
                        self._counters.callback_failed()
                        _log.exception("callback raised; the connector keeps running")
                if len(batch) < _BATCH:
                    break
