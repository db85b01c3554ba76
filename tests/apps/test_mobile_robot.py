"""Mobile robot end to end on the local backend: driving, odometry, lidar geometry, rates."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import pytest
import yaml

from simbridge.apps.mobile_robot import SCENE_PATH, MobileRobotResult, main, run_mobile_robot
from simbridge.apps.mobile_robot.driver import ScanSample
from simbridge.apps.summary import SUMMARY_KEYS
from simbridge.sim.sensors import SensorSuite
from simbridge.sim.world import World

DOCS = Path(__file__).resolve().parents[2] / "docs" / "sensors.md"

ROOM_HALF = 2.0
"""Wall inner faces at x, y = +-2 m (scene.yaml)."""
BOX_EAST_FACE = 1.45
"""box_east spans x in [1.45, 1.75], y in [0.85, 1.15]: 0.45 m from the leg x = 1."""


@pytest.fixture(scope="module")
def square() -> tuple[MobileRobotResult, str]:
    lines: list[str] = []
    result = run_mobile_robot(1.0, progress=lines.append)
    return result, "\n".join(lines)


def test_the_square_closes_and_odometry_matches_ground_truth(
    square: tuple[MobileRobotResult, str],
) -> None:
    result, progress = square
    assert result.error is None
    assert result.success
    for corner in ("(1.00, 0.00)", "(1.00, 1.00)", "(0.00, 1.00)", "(0.00, 0.00)"):
        assert corner in progress
    x, y, yaw = result.final_pose
    assert math.hypot(x, y) < 0.03  # back at the start (ground truth)
    assert abs(yaw) < math.radians(3)
    # /odom reports the simulated base itself: sub-millimetre once the robot stands still
    assert result.odom_error_m < 1e-3
    assert result.odom_yaw_error_deg < 0.1
    # dead reckoning from /joint_states drifts with wheel slip, but only a little
    assert 0 < result.wheel_odom_error_m < 0.10
    assert result.wheel_odom_yaw_error_deg < 8.0


def test_lidar_sees_the_room_at_its_known_distances(
    square: tuple[MobileRobotResult, str],
) -> None:
    result, _ = square
    scan = result.first_scan
    assert isinstance(scan, ScanSample)
    assert scan.stamp == pytest.approx(0.002, abs=1e-9)  # taken after the first step
    # the robot (laser on its centre line) still stands at the origin, facing +x
    for angle in (0.0, math.pi / 2, math.pi, -math.pi / 2):
        assert scan.range_at(angle) == pytest.approx(ROOM_HALF, abs=0.003), angle
    # the nearest return on the whole path: box_east's face, seen from the leg x = 1
    assert result.min_range_m == pytest.approx(BOX_EAST_FACE - 1.0, abs=0.02)


def test_sensor_rates_as_configured(square: tuple[MobileRobotResult, str]) -> None:
    result, _ = square
    assert result.sim_time > 20  # four 1 m legs and five turns
    assert result.scans_per_s == pytest.approx(10.0, rel=0.02)
    assert result.images_per_s == pytest.approx(10.0, rel=0.02)
    assert result.imu_per_s == pytest.approx(100.0, rel=0.02)
    assert result.odom_per_s == pytest.approx(50.0, rel=0.02)
    assert 0.5 < result.image_kib < 50  # 320x240 JPEG
    assert result.realtime_factor > 0


def test_unsubscribed_sensors_are_not_computed() -> None:
    result = run_mobile_robot(0.4, subscribe_sensors=False, progress=None)
    assert result.success
    assert result.scans_per_s == 0
    assert result.images_per_s == 0
    assert math.isinf(result.min_range_m)
    assert result.odom_per_s == pytest.approx(50.0, rel=0.02)


def test_main_prints_json_last_and_rejects_bad_sides(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["--side", "5"]) == 2
    assert "--side" in capsys.readouterr().err
    assert main(["--side", "0.3", "--json"]) == 0
    last = capsys.readouterr().out.strip().splitlines()[-1]
    summary = json.loads(last)
    assert summary["success"] is True
    assert list(summary)[:7] == list(SUMMARY_KEYS)
    assert (summary["seed"], summary["backend"]) == (None, "local")
    assert summary["scans_per_s"] == pytest.approx(10.0, rel=0.05)


def test_docs_worked_example_is_the_app_scene() -> None:
    text = DOCS.read_text()
    blocks = re.findall(r"```yaml\n(.*?)```", text, flags=re.DOTALL)
    documented = yaml.safe_load(blocks[-1])["sensors"]
    assert documented == yaml.safe_load(SCENE_PATH.read_text())["sensors"]
    world = World.from_scene(SCENE_PATH)
    suite = SensorSuite.from_config(world.model, documented)
    rows = re.findall(r"^\| `(/[^`]+)` \| ([a-z0-9_]+/\w+)", text, flags=re.MULTILINE)
    documented_topics = {topic: kind for topic, kind in rows if topic in suite.outputs}
    assert documented_topics == suite.outputs  # every sensor output, with its type
