"""Pick and place with the live view and a recording: the page's demo button, clicked in
headless Chromium, runs the task again with the next seed in a new world, and --record
writes the arm's motion."""

from __future__ import annotations

import threading
import time
from collections import Counter
from pathlib import Path

import pytest

from simbridge.apps.pick_and_place import AGAIN_LABEL, PickAndPlaceDemo, run_pick_and_place
from simbridge.apps.pick_and_place.task import PickAndPlaceTask
from simbridge.sim.record import RecordOptions
from simbridge.sim.record.player import recorded_messages

pytest.importorskip("viser")

from simbridge.sim.view import ViewOptions
from tests.apps.idle import assert_only_the_new_world_steps, idle_rate, serving
from tests.sim.browser import CHROMIUM, open_page


@pytest.mark.skipif(CHROMIUM is None, reason="Debian's chromium is not installed")
def test_the_pages_button_runs_again_with_a_new_seed(tmp_path: Path) -> None:
    said: list[str] = []
    with PickAndPlaceDemo(progress=said.append, view=ViewOptions(port=0)) as demo:
        first = demo.run(PickAndPlaceTask())
        assert first.success
        view = demo.view
        assert view is not None
        first_world = demo.world
        assert view.world is first_world
        stop = threading.Event()
        server = threading.Thread(target=demo.serve, args=(stop,))
        server.start()
        try:
            with open_page(view.url, tmp_path / "chrome") as browser:
                # viser takes a page's clicks once it reported its camera (connected)
                deadline = time.monotonic() + 90
                while not view.server.get_clients() and time.monotonic() < deadline:
                    time.sleep(0.1)
                # the mouse, in headless Chromium, until the demo says a run started (a press
                # while one is queued is ignored)
                browser.click_until(AGAIN_LABEL, lambda: _said(said, "again with seed"))
                deadline = time.monotonic() + 180
                while len(demo.results) < 2 and time.monotonic() < deadline:
                    time.sleep(0.05)
        finally:
            stop.set()
            server.join(180)
        assert len(demo.results) == 2, "the button started a second run"
        again = demo.results[1]
        assert again.seed == 1
        assert again.cube_start == PickAndPlaceTask.random(1).cube_center
        assert again.success, again.error
        assert view.world is demo.world is not first_world, "the view shows the new world"


def _said(lines: list[str], words: str) -> bool:
    return any(words in line for line in list(lines))


def test_the_world_keeps_stepping_at_real_time_between_runs() -> None:
    with PickAndPlaceDemo(progress=None, view=ViewOptions(port=0)) as demo:
        assert demo.run(PickAndPlaceTask()).success
        first = demo.world
        assert first is not None
        with serving(demo.serve, join_s=60):
            rate = idle_rate(first)
            assert 0.2 < rate < 1.15, f"idle stepping at {rate:.2f}x real time"
            cube = first.model.body("cube").id
            assert first.data.xpos[cube][2] > 0.0, "the cube rests on the table"
            demo.again()  # what the page's button does
            deadline = time.monotonic() + 60
            while len(demo.results) < 2 and time.monotonic() < deadline:
                time.sleep(0.05)
            assert len(demo.results) == 2
            second = demo.world
            assert second is not None
            assert_only_the_new_world_steps(first, second)
        assert not any(t.name == "pick-and-place-idle" for t in threading.enumerate())


def test_record_writes_the_arms_motion(tmp_path: Path) -> None:
    bag = tmp_path / "run.mcap"
    result = run_pick_and_place(progress=None, record=RecordOptions(bag))
    assert result.success
    topics = Counter(topic for topic, *_ in recorded_messages(bag))
    sim_s = result.sim_time
    assert topics["/joint_states"] == pytest.approx(50 * sim_s, abs=2)
    assert topics["/tf"] > 0


def test_cli_forwards_record_and_bridge_refuses_a_view(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from simbridge.cli import main

    bag = tmp_path / "cli.mcap"
    assert main(["demo", "pick-and-place", "--record", str(bag), "--realtime", "0"]) == 0
    assert Counter(topic for topic, *_ in recorded_messages(bag))["/joint_states"] > 100
    with pytest.raises(SystemExit) as exited:  # the bridge demo has no simulation to view
        main(["demo", "bridge", "--view"])
    assert exited.value.code == 2
    assert "unrecognized arguments: --view" in capsys.readouterr().err
