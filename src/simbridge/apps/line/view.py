"""The line's live view kept up across runs, with a "Run the line again" button.

`run_line(..., view=LineView(...))` shows each run's world in the same page; `serve`
then performs the runs the button queues (each with the next seed, in a new world that
the view shows in place of the last) on the caller's thread until stopped or Ctrl-C.
"""

from __future__ import annotations

import queue
import threading
from collections.abc import Callable

from simbridge.sim.view import LiveView, ViewOptions
from simbridge.sim.world import World

__all__ = ["AGAIN_LABEL", "LineView"]

AGAIN_LABEL = "Run the line again (new seed)"
"""The demo's button in the live view."""


class LineView:
    """The page the line's runs are shown in; close it (or use `with`) when done."""

    def __init__(
        self, options: ViewOptions, progress: Callable[[str], None] | None = print
    ) -> None:
        self.options = options
        self.say = progress or (lambda _text: None)
        self.view: LiveView | None = None
        self.seed = 0
        """The seed of the run shown last (or queued)."""
        self._requests: queue.Queue[int] = queue.Queue(maxsize=1)

    def show(self, world: World, seed: int) -> None:
        """Show a run's `world` (the first one starts the server and adds the button)."""
        self.seed = seed
        if self.view is None:
            self.view = LiveView(world, self.options)
            self.view.add_button(
                AGAIN_LABEL,
                self.again,
                hint="draw new part poses from the next seed and run the line again",
            )
            self.say(f"[line] live view at {self.view.url}")
        else:
            self.view.show(world)

    def again(self) -> None:
        """Queue a run with the next seed (what the button does); a press while one is
        already queued is ignored."""
        try:
            self._requests.put_nowait(self.seed + 1)
            self.seed += 1
        except queue.Full:
            self.say("[line] a run is already queued; press ignored")

    def serve(self, run: Callable[[int], object], stop: threading.Event | None = None) -> None:
        """Call `run(seed)` for each run the button queues until `stop` is set (or Ctrl-C)."""
        stop = stop or threading.Event()
        if self.view is not None:
            self.say(f"[line] serving {self.view.url}: '{AGAIN_LABEL}' runs again; Ctrl-C ends")
        try:
            while not stop.is_set():
                try:
                    seed = self._requests.get(timeout=0.1)
                except queue.Empty:
                    continue
                self.say(f"[line] again with seed {seed}")
                run(seed)
        except KeyboardInterrupt:
            pass

    def close(self) -> None:
        """Stop the view's server."""
        if self.view is not None:
            self.view.close()

    def __enter__(self) -> LineView:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
