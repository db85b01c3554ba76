"""The live view's on-demand overlays and controls, driven as a browser drives them (a
websocket client speaking viser's protocol): TF frames, contact points, the drag gizmo
moving a free body in MuJoCo, demo buttons, and several browsers at once."""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from simbridge.errors import SimError
from simbridge.sim.view import LiveView, ViewOptions, free_bodies
from simbridge.sim.world import World
from tests.sim.view.red_arm import red_arm_world, viewed

pytest.importorskip("viser")

import viser._messages as messages

from tests.sim.viser_client import ViserClient
from tests.waiting import wait_for

CRATE = {
    "name": "crate",
    "type": "box",
    "size": [0.1, 0.1, 0.1],
    "pose": {"xyz": [0.4, 0.0, 0.05]},
    "dynamic": True,
    "mass": 0.5,
}


@pytest.fixture
def running(tmp_path: Path) -> Iterator[tuple[World, LiveView]]:
    world = red_arm_world(tmp_path, ({"name": "floor", "type": "plane"}, CRATE))
    with viewed(world) as view:
        yield world, view


def test_tf_frames_appear_and_go_with_their_checkbox(running: tuple[World, LiveView]) -> None:
    world, view = running
    assert view.tf.frames == {}, "off by default"
    with ViserClient(view.port) as browser:
        browser.send(messages.GuiUpdateMessage(view.tf.checkbox._impl.uuid, {"value": True}))
        assert wait_for(lambda: len(view.tf.frames) == world.model.nbody - 1, timeout=60)
        names = {handle.name for handle in view.tf.frames.values()}
        assert {"/tf/upper", "/tf/crate"} <= names
        upper = world.model.body("upper").id
        assert wait_for(
            lambda: np.allclose(view.tf.frames[upper].position, world.data.xpos[upper]), timeout=10
        )
        browser.send(messages.GuiUpdateMessage(view.tf.checkbox._impl.uuid, {"value": False}))
        assert wait_for(lambda: view.tf.frames == {}, timeout=60)


def test_contact_points_on_demand(running: tuple[World, LiveView]) -> None:
    world, view = running
    time.sleep(0.3)  # the crate settles on the floor
    assert view.contacts.handle is None, "off by default"
    view.contacts.checkbox.value = True  # type: ignore[misc]
    assert wait_for(lambda: view.contacts.handle is not None, timeout=60)
    handle = view.contacts.handle
    assert handle is not None
    points = np.asarray(handle.points, dtype=np.float64)
    assert len(points) >= 4, "a box resting on a plane touches at its corners"
    crate = world.data.xpos[world.model.body("crate").id]
    assert np.abs(points[:, 2]).max() < 5e-3, "the contacts lie on the floor"
    assert np.abs(points[:, :2] - crate[:2]).max() < 0.06, "under the crate"


def test_dragging_the_gizmo_moves_the_body_in_mujoco(running: tuple[World, LiveView]) -> None:
    world, view = running
    crate = world.model.body("crate").id
    assert free_bodies(world.model) == {"crate": crate}
    view.toggle_pause()
    with ViserClient(view.port) as browser:
        browser.send(messages.GuiUpdateMessage(view.mover.dropdown._impl.uuid, {"value": "crate"}))
        assert wait_for(lambda: view.mover.gizmo is not None, timeout=60)
        target = (0.1, 0.5, 0.3)
        yaw = (np.cos(0.3), 0.0, 0.0, np.sin(0.3))
        browser.drag("/move_object", target, yaw)
        assert wait_for(lambda: np.allclose(world.data.xpos[crate], target, atol=1e-9), timeout=60)
        assert np.allclose(world.data.xquat[crate], yaw, atol=1e-9)
        view.toggle_pause()  # the physics takes over: it falls onto the floor below
        assert wait_for(lambda: abs(world.data.xpos[crate][2] - 0.05) < 2e-3, timeout=15)
        assert np.allclose(world.data.xpos[crate][:2], target[:2], atol=0.02)


def test_demo_buttons_run_what_the_app_registered(running: tuple[World, LiveView]) -> None:
    _, view = running
    pressed = threading.Event()
    view.add_button("Do it", pressed.set)
    with pytest.raises(SimError, match="Do it"):
        view.add_button("Do it", pressed.set)
    with ViserClient(view.port) as browser:
        browser.click(view.buttons["Do it"])
        assert pressed.wait(10)


def test_several_browsers_and_one_going_away_never_hold_the_physics(
    running: tuple[World, LiveView],
) -> None:
    world, view = running
    browsers = [ViserClient(view.port) for _ in range(3)]
    try:
        assert wait_for(lambda: len(view.server.get_clients()) == 3, timeout=60)
        assert wait_for(lambda: all(b.received > 20 for b in browsers), timeout=60), (
            "each gets the scene"
        )
        frames0 = view.frames_sent
        # The physics never waits on the view: with the streaming thread held inside a
        # push (its lock taken, as a push stuck on the browsers would hold it), sim time
        # goes on. Progress, not pace: a busy machine only makes it take longer.
        with view._lock:
            sim0 = world.time
            assert wait_for(lambda: world.time > sim0 + 0.3, timeout=60), "physics waited"
        browsers[0].socket.close_socket()  # gone without a goodbye, like a closed laptop
        assert wait_for(lambda: len(view.server.get_clients()) == 2, timeout=60)
        seen, sim1 = browsers[1].received, world.time
        assert wait_for(lambda: browsers[1].received > seen + 10, timeout=60), (
            "the others keep streaming"
        )
        assert wait_for(lambda: world.time > sim1 + 0.3, timeout=60), "the physics goes on"
        assert wait_for(lambda: view.frames_sent > frames0 + 30, timeout=60)
        # and it stays within its rate (30 Hz): a view looping flat out would starve the
        # physics of the interpreter lock. A slow machine only sends fewer.
        frames1, wall1 = view.frames_sent, time.perf_counter()
        time.sleep(1.0)
        sent, wall = view.frames_sent - frames1, time.perf_counter() - wall1
        assert sent <= 30 * wall + 2, f"{sent} frames in {wall:.2f} s at 30 Hz"
        assert view._thread.is_alive()
    finally:
        for browser in browsers:
            browser.close()


def _on_a_box(world: World, points: np.ndarray, tolerance: float = 0.01) -> np.ndarray:
    """Which points lie on the surface of one of the world's box geoms (walls, boxes)."""
    model, data = world.model, world.data
    hit = np.zeros(len(points), dtype=bool)
    for geom in range(model.ngeom):
        if int(model.geom_type[geom]) != 6:  # mjGEOM_BOX
            continue
        local = (points - data.geom_xpos[geom]) @ data.geom_xmat[geom].reshape(3, 3)
        outside = np.abs(local) - model.geom_size[geom]
        distance = np.where(
            (outside <= 0).all(axis=1),
            -outside.max(axis=1),  # inside: depth to the nearest face
            np.linalg.norm(np.maximum(outside, 0.0), axis=1),
        )
        hit |= distance < tolerance
    return hit


def test_lidar_returns_land_on_the_room_in_world_coordinates() -> None:
    """The feed turns the sensors' own messages (LaserScan, PointCloud2) into world points:
    in the mobile robot's walled room each lies on a wall, a box or the floor (within 1 cm
    of a box geom's surface or of z = 0), and most reach the walls' inner faces."""
    from simbridge.apps.mobile_robot.runner import SCENE_PATH
    from simbridge.sim.sensors import SensorSuite

    world = World.from_scene(SCENE_PATH)
    suite = SensorSuite.from_config(
        world.model,
        [
            {"type": "lidar_2d", "name": "flat", "body": "laser_link", "topic": "/scan",
             "samples": 360, "range_max": 8.0, "ignore_bodies": ["base_link", "camera_link"]},
            {"type": "lidar_3d", "name": "spin", "body": "base_link", "xyz": [0, 0, 0.4],
             "channels": 8, "samples": 180, "range_max": 8.0, "topic": "/points"},
        ],
    )  # fmt: skip
    view = LiveView(world, ViewOptions(port=0))
    try:
        feed = view.watch_sensors(suite)
        assert set(feed.lidars) == {"/scan", "/points"}
        world.refresh()
        publications = [p for s in suite.sensors for p in s.measure(world.model, world.data)]
        feed.observe(publications, world.data)
        for topic, least in (("/scan", 300), ("/points", 500)):
            points = feed.points[topic].astype(np.float64)
            assert len(points) > least, topic
            on_wall = np.abs(np.max(np.abs(points[:, :2]), axis=1) - 2.0) < 0.01
            on_surface = (np.abs(points[:, 2]) < 0.01) | _on_a_box(world, points)
            assert on_surface.mean() > 0.99, f"{topic}: returns off the room's surfaces"
            assert on_wall.mean() > 0.3, f"{topic}: most beams reach a wall"
    finally:
        view.close()
        suite.close()
