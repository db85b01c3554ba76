"""One server-wide memory budget, in bytes, shared by every client connection.

It bounds what clients can make the endpoint hold: partially received large frames,
messages queued for clients that read slowly, and control replies (topic lists,
errors, service frames) a client has not read yet. Each client may hold at most its
share; all together at most the limit. A request that does not fit is refused
(the caller drops a queued message, or closes the client with an `__error`).
"""

from __future__ import annotations

__all__ = ["MemoryBudget", "MemoryShare"]


class MemoryBudget:
    """`limit` bytes for the whole server; one client holds at most `client_share`."""

    __slots__ = ("client_share", "limit", "peak", "used")

    def __init__(self, limit: int, client_share: int) -> None:
        self.limit = limit
        self.client_share = min(client_share, limit)
        self.used = 0
        self.peak = 0

    def share(self) -> MemoryShare:
        """A new client's account."""
        return MemoryShare(self)


class MemoryShare:
    """What one client holds of the budget."""

    __slots__ = ("budget", "held")

    def __init__(self, budget: MemoryBudget) -> None:
        self.budget = budget
        self.held = 0

    def fits(self, nbytes: int) -> bool:
        """Whether `nbytes` more would fit both this client's share and the budget."""
        budget = self.budget
        return self.held + nbytes <= budget.client_share and budget.used + nbytes <= budget.limit

    def take(self, nbytes: int) -> bool:
        """Charge `nbytes` if they fit; False (nothing charged) if not."""
        if not self.fits(nbytes):
            return False
        self.held += nbytes
        budget = self.budget
        budget.used += nbytes
        budget.peak = max(budget.peak, budget.used)
        return True

    def give(self, nbytes: int) -> None:
        """Return `nbytes` taken before."""
        nbytes = min(nbytes, self.held)
        self.held -= nbytes
        self.budget.used -= nbytes

    def release(self) -> None:
        """Return everything (the client is gone)."""
        self.give(self.held)
