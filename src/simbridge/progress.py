"""A status line for long work (training, benchmarks, recording, data generation): what it is
doing now, redrawn about once a second on a terminal, so a run never looks hung.

Any layer may use it (like `errors`): it knows nothing of simbridge.
"""

from __future__ import annotations

import sys
import threading
import time
from collections.abc import Callable
from types import TracebackType
from typing import TextIO

__all__ = ["Ticker", "elapsed"]


def elapsed(seconds: float) -> str:
    """`42 s`, `3 min 05 s` or `1 h 02 min`: a duration as a status line shows it."""
    whole = int(seconds)
    if whole < 60:
        return f"{whole} s"
    if whole < 3600:
        return f"{whole // 60} min {whole % 60:02d} s"
    return f"{whole // 3600} h {whole % 3600 // 60:02d} min"


class Ticker:
    """While the `with` block runs, writes `status()` to `stream` (stderr): on a terminal
    every `every` seconds, redrawing one line (erased at the end); elsewhere (a log file, a
    pipe) as a new line every `plain_every` seconds, so logs stay short. A status that
    raises is shown as its error; the work goes on. Lines the work prints meanwhile go
    through `print`, which takes the status line away first."""

    def __init__(
        self,
        status: Callable[[], str],
        stream: TextIO | None = None,
        every: float = 1.0,
        plain_every: float = 10.0,
    ) -> None:
        self.status = status
        self.stream = stream if stream is not None else sys.stderr
        self.terminal = bool(getattr(self.stream, "isatty", lambda: False)())
        self.period = every if self.terminal else plain_every
        self.lines = 0
        """Status lines written so far (redraws included)."""
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="simbridge-ticker", daemon=True)
        self._width = 0
        self._lock = threading.Lock()  # the ticking thread vs `print`

    def __enter__(self) -> Ticker:
        self._thread.start()
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        error: BaseException | None,
        trace: TracebackType | None,
    ) -> None:
        self._stop.set()
        self._thread.join(timeout=5)
        with self._lock:
            self._erase()

    def print(self, text: str, file: TextIO | None = None) -> None:
        """Print a line of the work's own (to stdout by default) without mixing it into the
        status line; the next tick draws the status again."""
        with self._lock:
            self._erase()
            print(text, file=file if file is not None else sys.stdout, flush=True)

    def _erase(self) -> None:
        if self.terminal and self._width:
            self.stream.write("\r" + " " * self._width + "\r")
            self.stream.flush()
            self._width = 0

    def _run(self) -> None:
        next_at = time.monotonic() + self.period
        while not self._stop.wait(max(0.0, next_at - time.monotonic())):
            next_at += self.period
            try:
                text = self.status()
            except Exception as exc:  # a status must never stop the work it describes
                text = f"(status unavailable: {exc})"
            with self._lock:
                if self.terminal:
                    self.stream.write("\r" + text.ljust(self._width))
                    self._width = max(self._width, len(text))
                else:
                    self.stream.write(text + "\n")
                self.stream.flush()
                self.lines += 1
