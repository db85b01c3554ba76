"""RViz configs: the shipped demo configs are what `rviz_config` writes, a scene's config
has a display for each thing it publishes, and `simbridge rviz` names what is missing."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from simbridge.apps.rviz import DEMOS, demo_config_path, resolve_target, rviz_command, rviz_config
from simbridge.cli import main
from simbridge.errors import AppError
from tests.sim.urdf_samples import GRAVITY_ARM


def _displays(text: str) -> dict[str, dict[str, object]]:
    config = yaml.safe_load(text)["Visualization Manager"]
    return {d["Name"]: d for d in config["Displays"]}


@pytest.mark.parametrize("demo", sorted(DEMOS))
def test_shipped_config_is_what_rviz_config_writes(demo: str) -> None:
    shipped = demo_config_path(demo).read_text()
    assert shipped == rviz_config(DEMOS[demo]), (
        f"regenerate: simbridge rviz {demo} --write {demo_config_path(demo)}"
    )


def test_mobile_robot_config_shows_its_sensors_in_the_odom_frame() -> None:
    text = demo_config_path("mobile-robot").read_text()
    manager = yaml.safe_load(text)["Visualization Manager"]
    assert manager["Global Options"]["Fixed Frame"] == "odom"
    displays = _displays(text)
    assert displays["RobotModel diffbot"]["Robot Description"] == "/robot_description"
    assert displays["LaserScan /scan"]["Topic"] == "/scan"
    assert displays["Image /camera/image_raw"]["Image Topic"] == "/camera/image_raw"
    assert displays["Odometry /odom"]["Topic"] == "/odom"
    assert {d["Class"] for d in displays.values()} == {
        "rviz/Grid", "rviz/RobotModel", "rviz/TF", "rviz/LaserScan", "rviz/Image",
        "rviz/Odometry",
    }  # fmt: skip


def test_pick_and_place_config_is_in_the_world_frame() -> None:
    text = demo_config_path("pick-and-place").read_text()
    assert yaml.safe_load(text)["Visualization Manager"]["Global Options"]["Fixed Frame"] == (
        "world"
    )
    assert "RobotModel niryo_one" in _displays(text)


def test_point_clouds_and_namespaced_robots(tmp_path: Path) -> None:
    (tmp_path / "arm.urdf").write_text(GRAVITY_ARM)
    scene = {
        "robots": [
            {"urdf": "arm.urdf", "name": "left",
             "ros": {"namespace": "/left", "frame_prefix": "left/"}},
            {"urdf": "arm.urdf", "name": "right", "base": {"xyz": [0, 1, 0]},
             "ros": {"namespace": "/right", "frame_prefix": "right/"}},
        ],
        "sensors": [
            {"type": "lidar_3d", "name": "velo", "body": "left/base", "topic": "/points",
             "samples": 32, "channels": 4},
            {"type": "depth_camera", "name": "depth", "body": "left/base", "topic": "/depth_cam",
             "width": 32, "height": 24},
        ],
    }  # fmt: skip
    (tmp_path / "scene.yaml").write_text(yaml.safe_dump(scene))
    target = resolve_target(str(tmp_path / "scene.yaml"), tmp_path)
    displays = _displays(target.config.read_text())
    assert displays["RobotModel left"]["Robot Description"] == "/left/robot_description"
    assert displays["RobotModel left"]["TF Prefix"] == "left"
    assert displays["RobotModel right"]["Robot Description"] == "/right/robot_description"
    assert displays["PointCloud2 /points"]["Topic"] == "/points"
    assert displays["PointCloud2 /depth_cam/depth/points"]["Class"] == "rviz/PointCloud2"
    assert "Image /depth_cam/depth/image" in displays
    assert "Image /depth_cam/depth/image_raw" not in displays  # the same depth in mm


def test_missing_rviz_or_display_is_a_clear_error(tmp_path: Path) -> None:
    config = tmp_path / "x.rviz"
    with pytest.raises(AppError, match="rviz is not installed"):
        rviz_command(config, {"PATH": str(tmp_path), "DISPLAY": ":0"})
    fake = tmp_path / "rviz"
    fake.write_text("#!/bin/sh\n")
    fake.chmod(0o755)
    with pytest.raises(AppError, match="no display: DISPLAY is not set"):
        rviz_command(config, {"PATH": str(tmp_path)})
    assert rviz_command(config, {"PATH": str(tmp_path), "DISPLAY": ":3"}) == [
        str(fake), "-d", str(config),
    ]  # fmt: skip
    with pytest.raises(AppError, match="neither a demo"):
        resolve_target(str(tmp_path / "nope.yaml"), tmp_path)


def test_cli_writes_a_config(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "mobile.rviz"
    assert main(["rviz", "mobile-robot", "--write", str(out)]) == 0
    assert out.read_text() == demo_config_path("mobile-robot").read_text()
    assert f"rviz -d {out}" in capsys.readouterr().out
    assert main(["rviz", str(tmp_path / "missing.yaml")]) == 2
    assert "neither a demo" in capsys.readouterr().err


def test_pick_and_place_demo_feeds_rviz(monkeypatch: pytest.MonkeyPatch) -> None:
    """The demo sets the arm's description and publishes its joints and TF (what the
    shipped config shows), on the bus like on any graph."""
    from simbridge.apps.pick_and_place import demo, run_pick_and_place
    from simbridge.endpoint import LocalBus

    buses: list[LocalBus] = []
    published: dict[str, int] = {}

    class WatchedBus(LocalBus):
        def __init__(self) -> None:
            super().__init__()
            buses.append(self)

        def advertise(self, topic: str, msg_type: str, *, queue_size: int, latch: bool):  # type: ignore[no-untyped-def]
            publisher = super().advertise(topic, msg_type, queue_size=queue_size, latch=latch)
            publish = publisher.publish

            def counted(payload: bytes | bytearray) -> None:
                published[topic] = published.get(topic, 0) + 1
                publish(payload)

            publisher.publish = counted  # type: ignore[method-assign]
            return publisher

    monkeypatch.setattr(demo, "LocalBus", WatchedBus)
    result = run_pick_and_place("local", progress=None)
    assert result.success
    description = buses[0].get_param("/robot_description")
    assert '<robot name="niryo_one">' in description
    assert published["/tf_static"] == 1
    # 50 Hz of the run's sim time, give or take the last period
    assert published["/tf"] >= 50 * result.sim_time - 2
    assert published["/joint_states"] >= 50 * result.sim_time - 2
    assert "/clock" not in published
