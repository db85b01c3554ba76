"""The live view follows a moving robot and outlives the run: the cameras move with the
robot's base (headless Chromium keeps the mobile robot in the picture for 15 s of driving),
and `simbridge sim --view` paces at real time and serves until Ctrl-C after --duration."""

from __future__ import annotations

import math
import os
import re
import signal
import subprocess
import sys
import time
import urllib.request
from collections.abc import Iterator
from dataclasses import replace
from importlib import resources
from pathlib import Path

import numpy as np
import pytest

from simbridge.errors import SimError
from simbridge.sim.scene import load_scene
from simbridge.sim.world import World
from tests.sim.browser import CHROMIUM, keep_screenshot, open_page
from tests.sim.view.red_arm import viewed

pytest.importorskip("viser")

from simbridge.sim.view import LiveView, ViewOptions
from simbridge.sim.view.framing import DIRECTION

SCENE_PATH = Path(str(resources.files("simbridge") / "apps" / "mobile_robot" / "scene.yaml"))
"""The mobile-robot demo's room (by path: the demo's modules are not needed here)."""
WHEELS = ("left_wheel_joint", "right_wheel_joint")


def _base(world: World) -> np.ndarray:
    """Where diffbot's base is (m, world frame), as the last step left it: a read only, so
    safe beside the thread that steps the world."""
    return np.array(world.data.xpos[world.model.body("base_link").id])


def _drive(world: World, wheel_speed: float) -> None:
    """Both wheels at `wheel_speed` rad/s: diffbot drives straight along +x."""
    for joint in WHEELS:
        world.drives.set_velocity(joint, wheel_speed)


def test_the_cameras_move_with_the_followed_robot() -> None:
    world = World.from_scene(SCENE_PATH)
    view = LiveView(world, ViewOptions(port=0))
    try:
        assert view.follow.dropdown.value == "diffbot"  # the first robot, by default
        camera = view.server.initial_camera
        eye, target = np.array(camera.position), np.array(camera.look_at)
        start = _base(world)
        _drive(world, 4.0)
        view.push()
        world.run(2.0, 0.0)
        view.push()
        moved = _base(world) - start
        assert moved[0] > 0.3
        # the view sends poses as the last step left them (a step, 0.4 mm, behind)
        np.testing.assert_allclose(np.array(camera.look_at) - target, moved, atol=1e-3)
        np.testing.assert_allclose(np.array(camera.position) - eye, moved, atol=1e-3)
        view.follow.select("nothing")  # what the page's Follow menu does
        held = np.array(camera.look_at)
        world.run(1.0, 0.0)
        view.push()
        np.testing.assert_array_equal(np.array(camera.look_at), held)
    finally:
        view.close()


def test_an_unknown_body_to_follow_names_the_choices() -> None:
    world = World.from_scene(SCENE_PATH)
    with pytest.raises(SimError, match=r"cannot follow 'difbot'.*did you mean 'diffbot'\?"):
        LiveView(world, ViewOptions(port=0, follow="difbot"))
    view = LiveView(world, ViewOptions(port=0, follow="caster_link"))  # any body will do
    try:
        assert view.follow.body == world.model.body("caster_link").id
    finally:
        view.close()


PAGE = (1400, 800)
PANEL = 360
"""Pixels at the page's right taken by the control panel (its buttons are blue too)."""


def _robot_blue(pixels: np.ndarray) -> np.ndarray:
    """diffbot's blue body (0.2, 0.35, 0.7), shaded, in the 3D part of the page (left of
    the control panel, without the axes gizmo in its bottom-left corner)."""
    scene = pixels[:, : pixels.shape[1] - PANEL].copy()
    scene[-100:, :100] = 255
    r, g, b = scene[..., 0], scene[..., 1], scene[..., 2]
    return np.asarray((b > 90) & (b > 1.6 * r) & (b > 1.25 * g), dtype=bool)


@pytest.fixture
def driving() -> Iterator[tuple[World, LiveView]]:
    """The mobile robot in a live view, turned to drive across the view's first line of
    sight (where leaving the picture is quickest), stepping at three times real time."""
    scene = load_scene(SCENE_PATH)
    yaw = math.atan2(-DIRECTION[0], DIRECTION[1])  # square to the camera's horizontal axis
    # from the room's north-west, so 3 m of driving ends short of the south wall
    base = replace(scene.robots[0].base, xyz=(-1.1, 0.9, 0.05), rpy=(0.0, 0.0, yaw))
    robot = replace(scene.robots[0], base=base)
    world = World.from_scene(replace(scene, robots=(robot,)))
    # three times real time: each check pauses the world for its picture, so only the poses
    # matter, and 15 s of driving take 5
    with viewed(world, rate=20, realtime_factor=3.0) as view:
        yield world, view


@pytest.mark.skipif(CHROMIUM is None, reason="Debian's chromium is not installed")
def test_headless_chromium_keeps_the_driving_robot_in_frame(
    driving: tuple[World, LiveView], tmp_path: Path
) -> None:
    world, view = driving
    with open_page(view.url, tmp_path / "chrome", PAGE) as browser:
        deadline = time.monotonic() + 120
        while True:  # until the page has the scene and draws the robot
            pixels, _ = browser.shoot()
            if _robot_blue(pixels).sum() > 300 or time.monotonic() > deadline:
                break
            time.sleep(1.0)
        assert _robot_blue(pixels).sum() > 300, "the page never drew the robot"
        start = _base(world)
        world.post(lambda: _drive(world, 4.0))  # 0.2 m/s: 3 m in 15 s, far out of view
        began, give_up = world.time, time.monotonic() + 240
        for checkpoint in (5.0, 10.0, 15.0):  # sim seconds of driving
            while world.time - began < checkpoint:
                assert time.monotonic() < give_up, "the world stopped stepping"
                time.sleep(0.05)
            assert world.pause(wait=10)  # a still picture, however slow the screenshot
            time.sleep(1.5)  # the view sends the pose, the page draws it
            pixels, png = browser.shoot()
            (tmp_path / "last.png").write_bytes(png)
            blue = _robot_blue(pixels)
            rows, cols = np.nonzero(blue)
            at = f"{world.time - began:.1f} s, {np.linalg.norm(_base(world) - start):.2f} m out"
            assert blue.sum() > 300, f"the robot left the picture at {at}"
            height, width = blue.shape
            assert 0.05 * width < cols.mean() < 0.95 * width, f"at the edge at {at}"
            assert 0.05 * height < rows.mean() < 0.95 * height, f"at the edge at {at}"
            world.resume()
        assert np.linalg.norm(_base(world) - start) > 2.5  # it did drive away
    keep_screenshot(tmp_path / "last.png", "view-follow.png")


def test_sim_view_runs_in_real_time_and_stays_up_until_ctrl_c(tmp_path: Path) -> None:
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "osmesa")}
    command = [sys.executable, "-m", "simbridge.cli", "sim", str(SCENE_PATH), "--duration", "1"]
    proc = subprocess.Popen(
        [*command, "--view", "--view-port", "0"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
        cwd=tmp_path,
    )
    try:
        assert proc.stderr is not None
        lines: list[str] = []
        url = None
        deadline = time.monotonic() + 120
        while url is None and time.monotonic() < deadline:
            line = proc.stderr.readline()
            if not line:
                break
            lines.append(line)
            found = re.search(r"the live view stays at (http://\S+) until Ctrl-C", line)
            url = found[1] if found else None
        assert url is not None, "".join(lines)
        with urllib.request.urlopen(url, timeout=30) as page:  # served after the run
            assert page.status == 200
        assert proc.poll() is None
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0, err
    report = re.search(r"simulated (\S+) s in (\S+) s wall", out)
    assert report is not None, out
    sim, wall = float(report[1]), float(report[2])
    assert sim == pytest.approx(1.0, abs=0.01)
    assert wall >= 0.9 * sim  # paced: never faster than real time
