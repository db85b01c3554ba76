"""The status line of long work: redrawn on a terminal, a line now and then in a log, out
of the way of the work's own lines, never stopping the work."""

from __future__ import annotations

import io
import threading
from pathlib import Path

import pytest

from simbridge.progress import Ticker, elapsed
from simbridge.sim.record import RecordOptions
from simbridge.sim.record.recorder import Recorder
from tests.waiting import wait_for


class Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_a_log_gets_a_line_per_period() -> None:
    log = io.StringIO()
    calls = iter(range(1000))
    with Ticker(lambda: f"step {next(calls)}", stream=log, plain_every=0.01) as ticker:
        wait_for(lambda: ticker.lines >= 3, timeout=30)
    lines = log.getvalue().splitlines()
    assert lines[:3] == ["step 0", "step 1", "step 2"]
    assert "\r" not in log.getvalue()


def test_a_terminal_gets_one_redrawn_line_erased_at_the_end(
    capsys: pytest.CaptureFixture[str],
) -> None:
    screen = Terminal()
    texts = iter(["a long first status", "short"])
    done = threading.Event()

    def status() -> str:
        text = next(texts, None)
        if text is None:
            done.set()
            return "short"
        return text

    with Ticker(status, stream=screen, every=0.01) as ticker:
        assert done.wait(30)
        ticker.print("the work's own line")
    drawn = screen.getvalue()
    assert "\ra long first status" in drawn
    assert "\rshort" + " " * len(" first status") in drawn  # the longer text is covered
    assert drawn.endswith("\r" + " " * len("a long first status") + "\r") or drawn.endswith("\r")
    assert "\n" not in drawn
    assert capsys.readouterr().out == "the work's own line\n"


def test_a_failing_status_is_shown_and_the_work_goes_on() -> None:
    log = io.StringIO()

    def broken() -> str:
        raise RuntimeError("no figures yet")

    with Ticker(broken, stream=log, plain_every=0.01) as ticker:
        wait_for(lambda: ticker.lines >= 1, timeout=30)
    assert log.getvalue().splitlines()[0] == "(status unavailable: no figures yet)"


@pytest.mark.parametrize(
    ("seconds", "text"), [(0.4, "0 s"), (42.9, "42 s"), (185, "3 min 05 s"), (3725, "1 h 02 min")]
)
def test_elapsed(seconds: float, text: str) -> None:
    assert elapsed(seconds) == text


def test_a_recording_reports_what_it_wrote(tmp_path: Path) -> None:
    recorder = Recorder(RecordOptions(tmp_path / "run.mcap"), clock=lambda: 0.0)
    try:
        assert recorder.progress() == (
            "recording run.mcap: 0 messages on 0 topics, 0 dropped, 0 waiting"
        )
    finally:
        recorder.close()
