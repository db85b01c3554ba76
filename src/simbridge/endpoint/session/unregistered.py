"""Rate limit of one client's `__error`s about messages on topics it did not register, so a
flood of them (a wrong topic name in a loop, junk names) costs neither side much."""

from __future__ import annotations

__all__ = ["MAX_REMEMBERED", "UnregisteredReports"]

MAX_REMEMBERED = 1024
"""Unregistered topics remembered (to rate-limit their errors) before forgetting all."""


class UnregisteredReports:
    """One report per topic per `interval` seconds, and at most `per_interval` reports in
    any `interval`; the reports left out are counted and summed up in the next one."""

    def __init__(self, interval: float, per_interval: int) -> None:
        self._interval = interval
        self._per_interval = per_interval
        self._seen: dict[str, float] = {}
        self._window = 0.0
        self._reports = 0
        self._left_out = 0

    def __len__(self) -> int:
        """Topics remembered (never more than MAX_REMEMBERED)."""
        return len(self._seen)

    def forget(self, topic: str) -> None:
        """`topic` is registered now: a later message on it unregistered is reported at once."""
        self._seen.pop(topic, None)

    def due(self, topic: str, now: float) -> str | None:
        """Whether a message on `topic` at `now` is to be reported: None when not (counted
        if only the per-interval cap stopped it), else what to add to the report about
        those left out before it ('' when none were)."""
        if now - self._seen.get(topic, -1e9) < self._interval:
            return None
        if now - self._window >= self._interval:
            self._window, self._reports = now, 0
        if self._reports >= self._per_interval:
            self._left_out += 1
            return None
        self._reports += 1
        if len(self._seen) >= MAX_REMEMBERED:
            self._seen.clear()
        self._seen[topic] = now
        if not self._left_out:
            return ""
        left_out, self._left_out = self._left_out, 0
        return f" ({left_out} more messages on unregistered topics were not reported)"
