"""The live browser view (`simbridge sim --view`): shapes from the model, a real headless
Chromium drawing the robot, and the page's pause control stopping the sim clock."""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from simbridge.sim.view import LiveView, visual_shapes
from simbridge.sim.world import World
from tests.sim.browser import CHROMIUM, open_page
from tests.sim.view.red_arm import RED, red_arm_world, viewed
from tests.waiting import wait_for

pytest.importorskip("viser")


@pytest.fixture
def running(tmp_path: Path) -> Iterator[tuple[World, LiveView]]:
    world = red_arm_world(tmp_path)
    with viewed(world) as view:
        yield world, view


def test_shapes_are_the_urdf_visuals(tmp_path: Path) -> None:
    world = red_arm_world(tmp_path)
    shapes = [s for s in visual_shapes(world.model) if s.rgba == pytest.approx(RED)]
    kinds = sorted((s.kind, tuple(round(v, 6) for v in s.size)) for s in shapes)
    assert kinds == [("box", (0.08, 0.08, 0.4)), ("cylinder", (0.08, 0.1))]
    box = next(s for s in shapes if s.kind == "box")
    assert box.position == pytest.approx((0, 0, 0.2))
    assert np.abs(np.subtract(box.rgb255, (230, 13, 13))).max() <= 1  # float32 colours


def test_pause_in_the_page_stops_the_sim_clock(running: tuple[World, LiveView]) -> None:
    world, view = running
    time.sleep(0.3)
    view.toggle_pause()  # what the page's Pause button runs; returns once time is held
    held = world.time
    time.sleep(0.4)
    assert world.paused
    assert world.time == held
    view.step(25)
    deadline = time.monotonic() + 5
    while world.time < held + 25 * world.timestep - 1e-9 and time.monotonic() < deadline:
        time.sleep(0.01)
    assert world.time == pytest.approx(held + 25 * world.timestep)
    view.toggle_pause()
    assert wait_for(lambda: world.time > held + 0.1, timeout=10), "resume lets the clock run"
    assert view.frames_sent > 10, "poses keep streaming"


def test_pause_button_returns_once_the_step_in_progress_is_done(
    running: tuple[World, LiveView],
) -> None:
    """A step held open on the simulation thread: the button's pause waits for it, so the
    clock read right after the button stays put (the race CI saw on /simbridge/pause)."""
    world, view = running
    in_step, release = threading.Event(), threading.Event()

    def slow(_w: World) -> None:
        if not release.is_set():
            in_step.set()
            release.wait(10)

    def install() -> None:
        world.add_step_callback(slow)

    world.post(install)  # on the simulation thread
    assert in_step.wait(10)
    pauser = threading.Thread(target=view.toggle_pause)
    pauser.start()
    pauser.join(0.2)
    assert pauser.is_alive(), "the step is still running: the button must not return yet"
    release.set()
    pauser.join(10)
    assert not pauser.is_alive()
    held = world.time
    time.sleep(0.2)
    assert world.time == held
    assert view.controls.pause_button.label == "Resume"


@pytest.mark.skipif(CHROMIUM is None, reason="Debian's chromium is not installed")
def test_headless_chromium_draws_the_robot_and_its_pause_button_stops_the_clock(
    running: tuple[World, LiveView], tmp_path: Path
) -> None:
    world, view = running

    def robot_red(pixels: np.ndarray) -> np.ndarray:
        r, g, b = pixels[..., 0], pixels[..., 1], pixels[..., 2]
        # the robot's own red, not the pale red of the page still loading
        return np.asarray((r > 120) & (g < 0.45 * r) & (b < 0.45 * r), dtype=bool)

    with open_page(view.url, tmp_path / "chrome") as browser:
        deadline = time.monotonic() + 120
        while True:
            time.sleep(1.0)
            pixels, _ = browser.shoot()
            red = robot_red(pixels)
            if red.sum() > 500 or time.monotonic() > deadline:
                break
        assert red.sum() > 500, f"only {red.sum()} red pixels: the robot is not drawn"
        rows, cols = np.nonzero(red)
        # the camera looks at the robot: it is drawn around the middle of the page
        assert 0.2 * pixels.shape[1] < cols.mean() < 0.8 * pixels.shape[1]
        assert 0.15 * pixels.shape[0] < rows.mean() < 0.85 * pixels.shape[0]
        assert not world.paused
        browser.click_button("Pause")  # the mouse, in the page
        deadline = time.monotonic() + 30
        while view.controls.pause_button.label != "Resume" and time.monotonic() < deadline:
            time.sleep(0.05)  # the label changes once the step in progress is done
        assert world.paused, "the page's Pause button paused the world"
        held = world.time
        time.sleep(0.5)
        assert world.time == held, "the sim clock stopped"
        browser.click_button("Resume")  # the same button, relabelled
        deadline = time.monotonic() + 30
        while world.paused and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not world.paused
