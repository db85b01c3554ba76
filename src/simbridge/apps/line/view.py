"""The line's live view kept up across runs, with a "Run the line again" button.

`run_line(..., view=LineView(...))` shows each run's world in the same page; `serve`
then performs the runs the button queues (each with the next seed, in a new world that
the view shows in place of the last) on the caller's thread until stopped or Ctrl-C.
Between runs the shown world keeps stepping (at the last run's real-time factor, else
real time; apps/idle.py), so the page stays live and its controls act.
"""

from __future__ import annotations

import queue
import threading
from collections.abc import Callable

from simbridge.apps.idle import next_request
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
        self.realtime_factor = 0.0
        """The real-time factor of the run shown last: the world's pace between runs."""
        self._requests: queue.Queue[int] = queue.Queue(maxsize=1)

    def show(self, world: World, seed: int, realtime_factor: float = 0.0) -> None:
        """Show a run's `world` (the first one starts the server and adds the button);
        `realtime_factor` is the run's pace (0: flat out), kept between runs."""
        self.seed = seed
        self.realtime_factor = realtime_factor
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
        """Call `run(seed)` for each run the button queues until `stop` is set (or Ctrl-C);
        the shown world keeps stepping while none runs."""
        stop = stop or threading.Event()
        if self.view is not None:
            self.say(f"[line] serving {self.view.url}: '{AGAIN_LABEL}' runs again; Ctrl-C ends")
        try:
            while (seed := self._next_request(stop)) is not None:
                self.say(f"[line] again with seed {seed}")
                run(seed)
        except KeyboardInterrupt:
            pass

    def _next_request(self, stop: threading.Event) -> int | None:
        """The next queued seed, the shown world stepping meanwhile (apps/idle.py)."""
        world = self.view.world if self.view is not None else None
        return next_request(self._requests, stop, world, self.realtime_factor, "line-idle")

    def close(self) -> None:
        """Stop the view's server."""
        if self.view is not None:
            self.view.close()

    def __enter__(self) -> LineView:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
