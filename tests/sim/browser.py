"""Debian's headless Chromium for view tests, driven over the DevTools protocol: open a
page, take screenshots until one shows what the test waits for (the page may need a
while to receive the scene on a loaded machine), query the page and click its buttons
with the mouse, all bounded in time. The browser runs
in its own process group, killed whole at the end (its helper processes included)."""

from __future__ import annotations

import base64
import contextlib
import io
import itertools
import json
import os
import shutil
import signal
import subprocess
import tempfile
import time
import urllib.request
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
from PIL import Image
from websockets.sync.client import connect

__all__ = ["CHROMIUM", "Browser", "keep_screenshot", "open_page"]

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


class Browser:
    """One headless Chromium page at `url`; `shoot()` returns its pixels now."""

    def __init__(self, url: str, profile: Path, size: tuple[int, int] = (900, 700)) -> None:
        assert CHROMIUM is not None
        self.size = size
        command = [
            CHROMIUM,
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--no-first-run",
            f"--user-data-dir={profile}",
            "--enable-unsafe-swiftshader",  # WebGL in software (no GPU in CI)
            "--use-angle=swiftshader",
            f"--window-size={size[0]},{size[1]}",
            "--remote-debugging-address=127.0.0.1",
            "--remote-debugging-port=0",  # a free port, written to DevToolsActivePort
            url,
        ]
        # Chromium keeps its singleton socket in a folder of TMPDIR that a killed browser leaves
        # behind: give it a short one of its own (a socket path has at most 107 bytes), removed
        # on close.
        self._scratch = tempfile.mkdtemp(prefix="sbchrome")
        self.proc = subprocess.Popen(
            command,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            start_new_session=True,
            env={**os.environ, "TMPDIR": self._scratch},
        )
        self._ids = itertools.count(1)
        self.socket: Any = None
        try:
            port = self._devtools_port(profile / "DevToolsActivePort")
            self.socket = connect(self._page_socket(port), max_size=None, open_timeout=20)
        except BaseException:
            self.close()
            raise

    def _devtools_port(self, path: Path, timeout: float = 60.0) -> int:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            with contextlib.suppress(OSError, ValueError, IndexError):
                return int(path.read_text().splitlines()[0])
            time.sleep(0.1)
        raise AssertionError(f"chromium wrote no {path.name} within {timeout:g} s")

    @staticmethod
    def _page_socket(port: int, timeout: float = 30.0) -> str:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            with urllib.request.urlopen(f"http://127.0.0.1:{port}/json/list", timeout=5) as r:
                pages = [t for t in json.load(r) if t.get("type") == "page"]
            if pages:
                return str(pages[0]["webSocketDebuggerUrl"])
            time.sleep(0.2)
        raise AssertionError("chromium opened no page")

    def call(self, method: str, **params: Any) -> Any:
        """One DevTools command; its result."""
        ident = next(self._ids)
        self.socket.send(json.dumps({"id": ident, "method": method, "params": params}))
        while True:
            reply = json.loads(self.socket.recv(timeout=120))
            if reply.get("id") == ident:
                if "error" in reply:
                    raise AssertionError(f"{method}: {reply['error']}")
                return reply.get("result", {})

    def shoot(self) -> tuple[np.ndarray, bytes]:
        """The page as rgb ints (height, width, 3), and as PNG bytes."""
        png = base64.b64decode(self.call("Page.captureScreenshot", format="png")["data"])
        pixels = np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)
        return pixels, png

    def click_button(self, label: str, timeout: float = 60.0) -> None:
        """Click the page's button labelled `label` with the mouse (once it is shown)."""
        find = (
            "(() => { const b = [...document.querySelectorAll('button')].find("
            f"e => e.textContent.trim() === {json.dumps(label)});"
            " if (!b) return null; b.scrollIntoView({block: 'center'});"
            " const r = b.getBoundingClientRect(); return [r.x + r.width / 2, r.y + r.height / 2];"
            " })()"
        )
        deadline = time.monotonic() + timeout
        last = None
        while True:  # until the button is shown and stays put (panels animate open)
            found = self.call("Runtime.evaluate", expression=find, returnByValue=True)
            point = found.get("result", {}).get("value")
            if point and point == last:
                break
            if time.monotonic() > deadline:
                raise AssertionError(f"the page shows no button {label!r} (or it keeps moving)")
            last = point
            time.sleep(0.5)
        x, y = point
        for kind in ("mousePressed", "mouseReleased"):
            self.call("Input.dispatchMouseEvent", type=kind, x=x, y=y, button="left", clickCount=1)

    def click_until(
        self, label: str, done: Callable[[], bool], timeout: float = 120.0, retry_s: float = 15.0
    ) -> None:
        """Click button `label` until `done()` (a click the page takes before it wires the
        button is lost), waiting `retry_s` after each click; only for presses whose repeat
        is harmless while the first is being served."""
        deadline = time.monotonic() + timeout
        while not done() and time.monotonic() < deadline:
            self.click_button(label)
            pressed = time.monotonic() + retry_s
            while not done() and time.monotonic() < pressed:
                time.sleep(0.05)

    def close(self) -> None:
        """End the browser and every process it started."""
        if self.socket is not None:
            self.socket.close()
        with contextlib.suppress(ProcessLookupError):
            os.killpg(self.proc.pid, signal.SIGKILL)
        self.proc.wait()
        shutil.rmtree(self._scratch, ignore_errors=True)


@contextlib.contextmanager
def open_page(url: str, profile: Path, size: tuple[int, int] = (900, 700)) -> Iterator[Browser]:
    """A `Browser` on `url`, closed on exit."""
    browser = Browser(url, profile, size)
    try:
        yield browser
    finally:
        browser.close()


def keep_screenshot(shot: Path, name: str) -> None:
    """Copy `shot` to $SIMBRIDGE_SCREENSHOT_DIR/`name` when that is set (docs images)."""
    keep = os.environ.get("SIMBRIDGE_SCREENSHOT_DIR")
    if keep:
        shutil.copy(shot, Path(keep) / name)
