"""What a newcomer types wrong, through the command line: every case exits non-zero with
one `simbridge: error:` line that names the file, line and entry, what was expected and
the closest valid choice; nothing runs or is written first."""

from __future__ import annotations

import re
import socket
from collections.abc import Iterator
from pathlib import Path

import pytest

from simbridge.assets import robot_urdf
from simbridge.cli import main

DIFFBOT = robot_urdf("diffbot")

ROBOT = f"robots:\n  - urdf: {DIFFBOT}\n    fixed_base: false\n"

# (scene text, expected error after "simbridge: error: <file>:")
SCENES = [
    pytest.param(
        ROBOT + "sensors:\n"
        "  - {type: imu, name: imu, body: imu_link}\n"
        "  - type: lidar_2d\n"
        "    name: front\n"
        "    body: laser_link\n"
        "    rang_max: 8\n",
        r"9: sensors\[1\] \(lidar_2d 'front'\): unknown option 'rang_max'; "
        r"did you mean 'range_max'\? \(valid: ",
        id="sensor-option",
    ),
    pytest.param(
        ROBOT + "sensors:\n  - type: camera\n    name: cam\n    body: camera_link\n    widht: 64\n",
        r"8: sensors\[0\] \(camera 'cam'\): unknown option 'widht'; did you mean 'width'\?",
        id="camera-option",
    ),
    pytest.param(
        ROBOT + "sensors:\n  - type: lidar2d\n    name: front\n    body: laser_link\n",
        r"5: sensors\[0\]\.type: unknown sensor type 'lidar2d'; did you mean 'lidar_2d'\?",
        id="sensor-type",
    ),
    pytest.param(
        ROBOT + "sensors:\n  - type: imu\n    name: imu\n    body: base_lnk\n",
        r"7: sensors\[0\] \(imu 'imu'\)\.body: no body 'base_lnk' in the scene; "
        r"did you mean 'base_link'\? \(bodies: ",
        id="sensor-body",
    ),
    pytest.param(
        ROBOT + "    initial_position: {left_wheel_joint: 0}\n",
        r"4: robots\[0\]: unknown key 'initial_position'; did you mean 'initial_positions'\?",
        id="robot-key",
    ),
    pytest.param(
        ROBOT + "sensor:\n  - {type: imu, name: imu, body: imu_link}\n",
        r"4: top level: unknown key 'sensor'; did you mean 'sensors'\?",
        id="top-level-key",
    ),
    pytest.param(
        "physics:\n  timestep: 0.002\n gravity: [0, 0, -9.81]\n",
        r"3:2: not valid YAML: ",
        id="yaml-syntax",
    ),
    pytest.param(
        "robots:\n  - urdf: nothere.urdf\n",
        r"2: robots\[0\]\.urdf: file '.*nothere\.urdf' does not exist",
        id="missing-urdf",
    ),
    # Found when the scene is built (the URDF loaded), still at the entry's line:
    pytest.param(
        ROBOT + "    drives:\n      joints:\n        left_wheel_jiont: {mode: velocity}\n",
        r"6: robots\[0\]\.drives\.joints\.left_wheel_jiont: 'left_wheel_jiont' is not a "
        r"drivable joint of robot 'diffbot'; did you mean 'left_wheel_joint'\? \(revolute/",
        id="drive-joint",
    ),
    pytest.param(
        ROBOT + "    initial_positions:\n      right_wheel: 0.1\n",
        r"5: robots\[0\]\.initial_positions\.right_wheel: 'right_wheel' is not a drivable "
        r"joint of robot 'diffbot'; did you mean 'right_wheel_joint'\?",
        id="initial-position-joint",
    ),
    pytest.param(
        ROBOT + "  - urdf: " + str(DIFFBOT) + "\n",
        r"4: robots\[1\]: robot 'diffbot': bodies base_link, .* already exist in the model "
        r"\(give the robot a name prefix\)",
        id="robot-bodies-taken",
    ),
    pytest.param(
        ROBOT + "    prefix: a/\n  - urdf: " + str(DIFFBOT) + "\n    prefix: b/\n",
        r"5: robots\[1\]: the robot name 'diffbot' is already taken by robots\[0\]",
        id="robot-name-taken",
    ),
    pytest.param(
        ROBOT + "    ros:\n      controllers:\n        base_controller:\n"
        "          type: joint_group_velocity_controller\n"
        "          joints: [left_wheel_joint, rigth_wheel_joint]\n",
        r"8: robots\[0\]\.ros\.controllers\.base_controller\.joints: 'rigth_wheel_joint' is not "
        r"a drivable joint of robot 'diffbot'; did you mean 'right_wheel_joint'\?",
        id="controller-joint",
    ),
    pytest.param(
        ROBOT + "    ros:\n      diff_drive: {left: left_wheel_joint, right: right_wheel}\n",
        r"5: robots\[0\]\.ros\.diff_drive\.right: 'right_wheel' is not a drivable joint of "
        r"robot 'diffbot'; did you mean 'right_wheel_joint'\?",
        id="diff-drive-joint",
    ),
    pytest.param(
        "objects:\n  - name: part\n    type: mesh\n    mesh: nothere.stl\n",
        r"4: objects\[0\]\.mesh: file '.*nothere\.stl' does not exist",
        id="missing-object-mesh",
    ),
    pytest.param(
        "lights:\n  - {name: sun, dir: [0, 0, 0]}\n",
        r"2: lights\[0\]\.dir: must not be \[0, 0, 0\]",
        id="light-direction",
    ),
]


@pytest.mark.parametrize(("text", "expected"), SCENES)
def test_a_bad_scene_is_one_error_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str, expected: str
) -> None:
    scene = tmp_path / "scene.yaml"
    scene.write_text(text)
    assert main(["sim", str(scene), "--duration", "0.01"]) == 2
    captured = capsys.readouterr()
    assert "simulated" not in captured.out
    error = _error_line(captured.err)
    assert re.match(rf"simbridge: error: {re.escape(str(scene))}:{expected}", error), error


def test_a_mistyped_shipped_scene_names_the_closest(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["sim", "mobile-robt", "--duration", "0.01"]) == 2
    error = _error_line(capsys.readouterr().err)
    assert error == (
        "simbridge: error: no scene file or shipped scene 'mobile-robt'; did you mean "
        "'mobile-robot'? (shipped: mobile-robot, pick-and-place, line, reach; or a path to a "
        "scene YAML file)"
    )


def test_a_missing_mesh_lists_where_it_looked_and_how_to_add_a_folder(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "r.urdf").write_text(
        '<robot name="r"><link name="a"><collision><geometry>'
        '<mesh filename="package://arm_meshes/base.stl"/></geometry></collision></link></robot>'
    )
    (tmp_path / "scene.yaml").write_text("robots:\n  - urdf: r.urdf\n")
    assert main(["sim", str(tmp_path / "scene.yaml"), "--duration", "0.01"]) == 2
    error = _error_line(capsys.readouterr().err)
    assert "package 'arm_meshes' of 'package://arm_meshes/base.stl' not found" in error
    assert f"searched {tmp_path} and every folder above it" in error
    assert "--search-path DIR, `search_paths: [DIR]` on the scene's robot" in error


@pytest.fixture
def refusing_port() -> Iterator[int]:
    """A loopback port that refuses connections (bound, never listening) while held."""
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        yield sock.getsockname()[1]


def test_an_endpoint_that_never_answers_fails_the_run(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], refusing_port: int
) -> None:
    scene = tmp_path / "scene.yaml"
    scene.write_text(ROBOT)
    bag = tmp_path / "out.mcap"
    args = ["sim", str(scene), "--endpoint", f"127.0.0.1:{refusing_port}", "--duration", "1"]
    assert main([*args, "--connect-timeout", "0.5", "--record", str(bag)]) == 2
    captured = capsys.readouterr()
    assert "simulated" not in captured.out
    error = _error_line(captured.err)
    assert f"no ROS-TCP endpoint answered at 127.0.0.1:{refusing_port} within 0.5 s" in error
    assert "--wait-for-endpoint" in error
    assert not bag.exists()


def _error_line(stderr: str) -> str:
    """The one `simbridge: error:` line (warnings and log lines may come before it)."""
    errors = [line for line in stderr.splitlines() if line.startswith("simbridge: error:")]
    assert len(errors) == 1, stderr
    return errors[0]
