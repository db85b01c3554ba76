"""The line with the live view: the page's demo button, clicked in headless Chromium, runs
the line again with the next seed in a new world that the same page shows."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from simbridge.apps.line import AGAIN_LABEL, LineResult, LineView, run_line

pytest.importorskip("viser")

from simbridge.sim.view import ViewOptions
from tests.apps.idle import assert_only_the_new_world_steps, idle_rate, serving
from tests.sim.browser import CHROMIUM, open_page


@pytest.mark.skipif(CHROMIUM is None, reason="Debian's chromium is not installed")
def test_the_pages_button_runs_the_line_again_with_a_new_seed(tmp_path: Path) -> None:
    results: list[LineResult] = []
    said: list[str] = []
    with LineView(ViewOptions(port=0), progress=said.append) as line_view:
        results.append(run_line(None, 1, view=line_view, progress=None))
        assert results[0].success, results[0].error
        view = line_view.view
        assert view is not None
        first_world = view.world
        assert AGAIN_LABEL in view.buttons
        with (
            serving(_server(line_view, results), join_s=120),
            open_page(view.url, tmp_path / "chrome") as browser,
        ):
            # viser takes a page's clicks once it reported its camera (connected)
            deadline = time.monotonic() + 90
            while not view.server.get_clients() and time.monotonic() < deadline:
                time.sleep(0.1)
            # the mouse, in headless Chromium, until the line says a run started (a press
            # while one is queued is ignored)
            browser.click_until(AGAIN_LABEL, lambda: any("again with seed" in s for s in said))
            deadline = time.monotonic() + 180
            while len(results) < 2 and time.monotonic() < deadline:
                time.sleep(0.05)
        assert len(results) == 2, "the button started a second run"
        again = results[1]
        assert again.seed == 1
        assert again.success, again.error
        assert again.final_positions != results[0].final_positions
        assert view.world is not first_world, "the view shows the new run's world"
        assert line_view.view is view, "in the same page"


def test_the_world_keeps_stepping_at_real_time_between_runs() -> None:
    with LineView(ViewOptions(port=0), progress=None) as line_view:
        results = [run_line(None, 1, view=line_view, progress=None, realtime_factor=0.0)]
        assert results[0].success, results[0].error
        view = line_view.view
        assert view is not None
        first = view.world
        with serving(_server(line_view, results), join_s=120):
            rate = idle_rate(first)
            assert 0.2 < rate < 1.15, f"idle stepping at {rate:.2f}x real time (0: flat out)"
            line_view.again()  # what the page's button does
            deadline = time.monotonic() + 90
            while len(results) < 2 and time.monotonic() < deadline:
                time.sleep(0.05)
            assert len(results) == 2
            assert_only_the_new_world_steps(first, view.world)
        assert not any(t.name == "line-idle" for t in threading.enumerate())


def _server(line_view: LineView, results: list[LineResult]) -> Callable[[threading.Event], None]:
    """`LineView.serve`, each button press running the line once more into `results`."""

    def serve(stop: threading.Event) -> None:
        line_view.serve(
            lambda seed: results.append(run_line(seed, 1, view=line_view, progress=None)),
            stop=stop,
        )

    return serve
