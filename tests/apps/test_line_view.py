"""The line with the live view: the page's demo button, clicked in headless Chromium, runs
the line again with the next seed in a new world that the same page shows."""

from __future__ import annotations

import threading
import time
from pathlib import Path

import pytest

from simbridge.apps.line import AGAIN_LABEL, LineResult, LineView, run_line

pytest.importorskip("viser")

from simbridge.sim.view import ViewOptions
from tests.sim.browser import CHROMIUM, open_page


@pytest.mark.skipif(CHROMIUM is None, reason="Debian's chromium is not installed")
def test_the_pages_button_runs_the_line_again_with_a_new_seed(tmp_path: Path) -> None:
    results: list[LineResult] = []
    with LineView(ViewOptions(port=0), progress=None) as line_view:
        results.append(run_line(None, 1, view=line_view, progress=None))
        assert results[0].success, results[0].error
        view = line_view.view
        assert view is not None
        first_world = view.world
        assert AGAIN_LABEL in view.buttons
        stop = threading.Event()
        server = threading.Thread(
            target=line_view.serve,
            args=(lambda seed: results.append(run_line(seed, 1, view=line_view, progress=None)),),
            kwargs={"stop": stop},
        )
        server.start()
        try:
            with open_page(view.url, tmp_path / "chrome") as browser:
                # viser takes a page's clicks once it reported its camera (connected)
                deadline = time.monotonic() + 90
                while not view.server.get_clients() and time.monotonic() < deadline:
                    time.sleep(0.1)
                browser.click_button(AGAIN_LABEL)  # the mouse, in headless Chromium
                deadline = time.monotonic() + 90
                while len(results) < 2 and time.monotonic() < deadline:
                    time.sleep(0.05)
        finally:
            stop.set()
            server.join(120)
        assert not server.is_alive()
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
        stop = threading.Event()
        server = threading.Thread(
            target=line_view.serve,
            args=(lambda seed: results.append(run_line(seed, 1, view=line_view, progress=None)),),
            kwargs={"stop": stop},
        )
        server.start()
        try:
            time.sleep(0.3)
            sim0, wall0 = first.time, time.perf_counter()
            time.sleep(1.5)
            rate = (first.time - sim0) / (time.perf_counter() - wall0)
            assert 0.2 < rate < 1.15, f"idle stepping at {rate:.2f}x real time (0: flat out)"
            line_view.again()  # what the page's button does
            deadline = time.monotonic() + 90
            while len(results) < 2 and time.monotonic() < deadline:
                time.sleep(0.05)
            assert len(results) == 2
            second = view.world
            assert second is not first
            held = first.time
            sim0 = second.time
            time.sleep(0.5)
            assert first.time == held, "the previous world no longer steps"
            assert second.time > sim0, "the new world steps while idle"
        finally:
            stop.set()
            server.join(120)
        assert not server.is_alive()
        assert not any(t.name == "line-idle" for t in threading.enumerate())
