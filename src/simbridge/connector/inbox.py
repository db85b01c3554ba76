"""The dispatcher's queue: received payloads for their callbacks, and tasks.

Every received message passes through here, so queuing one allocates nothing beyond
the `(receiver, payload)` pair the reader makes: the pairs go into one deque as they
are, with a count per receiver for its bound. A payload dropped to keep a receiver
within its `queue_size` stays in the deque and is skipped when taken: a drop always
hits the receiver's oldest payload, which is the first of its entries still in the
deque, so a count of dropped entries per receiver says which ones to skip.
"""

from __future__ import annotations

import threading
from collections import deque
from collections.abc import Callable, Sequence
from typing import Protocol

__all__ = ["Entry", "Inbox", "Receiver", "Task"]

Task = Callable[[], None]


class Receiver(Protocol):
    """Takes received payloads one at a time (a subscription)."""

    topic: str
    queue_size: int
    """Payloads that may wait for it; the oldest is dropped beyond."""

    def deliver(self, payload: bytes) -> None:
        """Handle one payload."""


Entry = tuple[Receiver, bytes] | tuple[None, Task]
"""A payload and its receiver, or a task (no receiver)."""


class Inbox:
    """FIFO of payloads (at most `queue_size` waiting per receiver, the oldest dropped)
    and tasks (never dropped), for many producers and one consumer at a time; the
    `Dispatcher` says who consumes and wakes it."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._order: deque[Entry] = deque()
        self._live: dict[Receiver, int] = {}
        """Payloads queued per receiver, not counting dropped ones."""
        self._skip: dict[Receiver, int] = {}
        """Dropped payloads per receiver that are still in `_order`."""
        self.count = 0
        """Entries queued (not counting dropped payloads); `len(inbox)` without a call of
        a Python method, for the dispatcher's checks on every read."""

    def __len__(self) -> int:
        return self.count

    def put_messages(self, entries: Sequence[tuple[Receiver, bytes]]) -> list[Receiver]:
        """Queue payloads for their receivers, in order; returns one receiver per payload
        dropped to keep it within its `queue_size`."""
        dropped: list[Receiver] = []
        with self._lock:
            self._order.extend(entries)
            live = self._live
            added = 0
            for receiver, _ in entries:
                count = live.get(receiver, 0)
                if count < receiver.queue_size:
                    live[receiver] = count + 1
                    added += 1
                else:
                    self._skip[receiver] = self._skip.get(receiver, 0) + 1
                    dropped.append(receiver)
            self.count += added
        return dropped

    def put_task(self, task: Task) -> None:
        """Queue `task` after everything queued so far."""
        with self._lock:
            self._order.append((None, task))
            self.count += 1

    def take(self, max_items: int) -> list[Entry]:
        """Remove and return up to `max_items` entries in order (dropped ones skipped)."""
        out: list[Entry] = []
        with self._lock:
            order = self._order
            live = self._live
            skip = self._skip
            while order and len(out) < max_items:
                entry = order.popleft()
                receiver = entry[0]
                if receiver is not None:
                    skipped = skip.get(receiver)
                    if skipped:
                        if skipped == 1:
                            del skip[receiver]
                        else:
                            skip[receiver] = skipped - 1
                        continue
                    left = live[receiver] - 1
                    if left:
                        live[receiver] = left
                    else:
                        del live[receiver]
                out.append(entry)
            self.count -= len(out)
        return out

    def pending(self, receiver: Receiver) -> int:
        """Payloads of `receiver` queued (not counting dropped ones)."""
        return self._live.get(receiver, 0)
