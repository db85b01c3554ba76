"""The view draws what the sensors measure, in a real headless Chromium: the mobile
robot's lidar returns as points, its camera's images in the panel, contact points and TF
frames on demand. The browser watching is what switches the sensors on: no ROS node
subscribes here. The screenshot is the README's (docs/view.png)."""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from simbridge.apps.mobile_robot.runner import SCENE_PATH
from simbridge.connector import ConnectorOptions
from simbridge.endpoint import EndpointOptions, EndpointThread, LocalBus
from simbridge.sim.runner import SimulationSession
from simbridge.sim.view import LIDAR_RGB, LiveView, ViewOptions
from tests.sim.browser import CHROMIUM, keep_screenshot, open_page

pytest.importorskip("viser")


@pytest.fixture
def robot_view() -> Iterator[tuple[SimulationSession, LiveView]]:
    with (
        EndpointThread(EndpointOptions(port=0), LocalBus()) as endpoint,
        SimulationSession(
            SCENE_PATH,
            f"127.0.0.1:{endpoint.port}",
            ConnectorOptions(reconnect_initial=0.2),
            connect_timeout=60.0,  # generous: a loaded machine may take long to connect
        ) as session,
    ):
        assert session.sensors is not None
        view = LiveView(session.world, ViewOptions(port=0))
        session.sensors.add_observer(view.watch_sensors(session.sensors.suite))
        runner = threading.Thread(target=session.world.run, kwargs={"realtime_factor": 1.0})
        runner.start()
        yield session, view
        session.world.stop()
        runner.join(10)
        view.close()


def _lidar_pixels(pixels: np.ndarray) -> np.ndarray:
    r, g, b = pixels[..., 0], pixels[..., 1], pixels[..., 2]
    near = (np.abs(r - LIDAR_RGB[0]) < 40) & (np.abs(g - LIDAR_RGB[1]) < 40) & (b > 215)
    return np.asarray(near, dtype=bool)


@pytest.mark.skipif(CHROMIUM is None, reason="Debian's chromium is not installed")
def test_chromium_shows_lidar_points_camera_images_contacts_and_frames(
    robot_view: tuple[SimulationSession, LiveView], tmp_path: Path
) -> None:
    session, view = robot_view
    feed = view.sensors
    assert feed is not None
    assert feed.images_shown == 0, "nobody watches yet: nothing measured"
    assert not feed.points
    view.tf.checkbox.value = True  # type: ignore[misc]
    view.contacts.checkbox.value = True  # type: ignore[misc]
    nbody = session.world.model.nbody
    images = "[...document.querySelectorAll('img')].map(i => [i.naturalWidth, i.naturalHeight])"
    with open_page(view.url, tmp_path / "chrome", size=(1000, 760)) as browser:
        deadline = time.monotonic() + 120
        while True:
            time.sleep(1.0)
            pixels, png = browser.shoot()
            shown = browser.call("Runtime.evaluate", expression=images, returnByValue=True)
            sizes = shown.get("result", {}).get("value") or []
            drawn = _lidar_pixels(pixels).sum() > 300 and [320, 240] in sizes
            # the overlays follow the checkboxes at the view's next updates
            overlays = view.contacts.count >= 3 and len(view.tf.frames) == nbody - 1
            if (drawn and overlays) or time.monotonic() > deadline:
                break
    (tmp_path / "view.png").write_bytes(png)
    assert [320, 240] in sizes, f"the page shows no 320x240 camera image (images: {sizes})"
    cyan = _lidar_pixels(pixels)
    assert cyan.sum() > 300, f"only {cyan.sum()} lidar-coloured pixels: no points drawn"
    scan = next(iter(feed._drawn.values()))
    points = np.asarray(scan.points, dtype=np.float64)
    assert len(points) > 300, "a closed room returns nearly every beam"
    # every return lies on a wall (inner faces at |x| = 2 or |y| = 2) or on a box
    inside = np.max(np.abs(points[:, :2]), axis=1)
    assert inside.max() < 2.0 + 0.05
    assert np.mean(inside > 1.95) > 0.5, "most beams reach the walls"
    assert feed.images_shown > 0, "the camera panel got images"
    camera = feed._panels["camera"]
    assert camera.image.shape == (240, 320, 3)
    assert camera.image.std() > 5, "a rendered view, not a blank"
    assert view.contacts.count >= 3, "the wheels and caster touch the floor"
    assert len(view.tf.frames) == nbody - 1
    keep_screenshot(tmp_path / "view.png", "view.png")
