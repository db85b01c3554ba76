"""A subprocess whose stdout and stderr are read all the time into bounded tails.

A process started with pipes that nobody reads blocks once a pipe buffer (64 KiB on
Linux) fills: a chatty ROS tool (`rostopic echo`, a node logging to the console) would
stall mid-run. `RosCore.spawn` starts its processes as a `DrainedProcess`, so the output
is kept (the last `limit` characters of each stream) without ever blocking the child.
"""

from __future__ import annotations

import codecs
import subprocess
import threading
from collections.abc import Sequence
from typing import IO

__all__ = ["DrainedProcess"]


class _Tail:
    """The last `limit` characters read from one pipe, and how many were dropped before."""

    def __init__(self, limit: int) -> None:
        self.limit = limit
        self.dropped = 0
        self._text = ""
        self._lock = threading.Lock()

    def add(self, chunk: str) -> None:
        with self._lock:
            text = self._text + chunk
            if len(text) > self.limit:
                self.dropped += len(text) - self.limit
                text = text[-self.limit :]
            self._text = text

    def text(self) -> str:
        with self._lock:
            if self.dropped:
                return f"[... {self.dropped} earlier characters dropped ...]\n{self._text}"
            return self._text


class DrainedProcess(subprocess.Popen[str]):
    """A process in its own session whose stdout and stderr are read all the time by two
    threads into bounded tails (`limit` characters each), so a chatty process never blocks
    on a full pipe that its owner reads only at the end (or never). `output()` is what it
    wrote so far; `communicate()` waits and returns the tails, as Popen's would."""

    def __init__(self, args: Sequence[str], env: dict[str, str], limit: int = 1 << 20) -> None:
        super().__init__(
            list(args),
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            stdin=subprocess.DEVNULL,
            text=True,
            start_new_session=True,
        )
        self._tails = (_Tail(limit), _Tail(limit))
        self._readers = [
            threading.Thread(target=self._drain, args=(pipe, tail), daemon=True)
            for pipe, tail in zip((self.stdout, self.stderr), self._tails, strict=True)
        ]
        for reader in self._readers:
            reader.start()

    @staticmethod
    def _drain(pipe: IO[str] | None, tail: _Tail) -> None:
        if pipe is None:
            return
        decoder = codecs.getincrementaldecoder("utf-8")(errors="replace")
        raw = pipe.buffer  # type: ignore[attr-defined]  # the text wrapper's binary pipe
        while chunk := raw.read1(65536):
            tail.add(decoder.decode(chunk).replace("\r\n", "\n"))
        tail.add(decoder.decode(b"", final=True))

    def output(self) -> tuple[str, str]:
        """(stdout, stderr) read so far."""
        return self._tails[0].text(), self._tails[1].text()

    def communicate(
        self, input: str | None = None, timeout: float | None = None
    ) -> tuple[str, str]:
        """Wait for the process (TimeoutExpired after `timeout` s) and return its output."""
        if input is not None:
            raise ValueError("a DrainedProcess has no stdin")
        self.wait(timeout)
        for reader in self._readers:  # EOF soon after exit, unless a child keeps the pipe
            reader.join(5)
        return self.output()
