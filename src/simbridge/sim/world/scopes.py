"""Context managers wrapped around a world's step callbacks (`World.add_callback_scope`).

A scope such as `Connector.batch()` is entered before the first due callback and left
once no callback runs for a while: at the end of `World.step`, and inside `World.run`
when the run is about to sleep or pause, when it ends, or when the scope has been open
for `window` seconds of wall time. What the callbacks of those steps publish then
leaves together, in one write instead of one per step (at full speed, a step takes tens
of microseconds and a socket write about as long).
"""

from __future__ import annotations

import time
from contextlib import AbstractContextManager

__all__ = ["CallbackScopes"]


class CallbackScopes:
    """The scopes of one world and whether they are entered now."""

    def __init__(self, window: float) -> None:
        self.window = window
        """Wall-clock seconds the scopes may stay entered across steps (0: left after
        each step's callbacks)."""
        self._scopes: dict[int, AbstractContextManager[object]] = {}
        self._entered: list[AbstractContextManager[object]] | None = None
        self._since = 0.0
        self.open = False
        """Whether the scopes are entered now."""

    def add(self, key: int, scope: AbstractContextManager[object]) -> None:
        """Use `scope` from the next time the scopes are entered."""
        self._scopes[key] = scope

    def remove(self, key: int) -> None:
        """Stop using a scope (left first if entered now)."""
        if key in self._scopes and self.open:
            self.close()
        self._scopes.pop(key, None)

    def enter(self) -> None:
        """Enter every scope (nothing when entered already or when there are none)."""
        if self.open or not self._scopes:
            return
        entered: list[AbstractContextManager[object]] = []
        self._entered = entered
        self.open = True
        self._since = time.perf_counter()
        for scope in list(self._scopes.values()):
            scope.__enter__()
            entered.append(scope)

    def close(self) -> None:
        """Leave the entered scopes, innermost first."""
        entered, self._entered = self._entered, None
        self.open = False
        if entered:
            for scope in reversed(entered):
                scope.__exit__(None, None, None)

    def close_if_due(self) -> None:
        """Leave the scopes when they have been entered for `window` seconds."""
        if self.open and time.perf_counter() - self._since >= self.window:
            self.close()
