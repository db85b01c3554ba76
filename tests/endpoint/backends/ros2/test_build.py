"""`simbridge msg build`: ROS 1/2 definitions -> rosidl packages built into the ROS 2 venv."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from tests.ros2support import child_env, require_ros2

from simbridge.endpoint.backends.ros2.build import (
    InterfaceBuildError,
    build_packages,
    load_package,
    ros2_definition,
)
from simbridge.messages.registry import SHIPPED_DEFINITIONS


def test_ros1_spellings_become_ros2_ones() -> None:
    text = (
        "Header header  # stamp\ntime[] stamps\nduration wait\nmy_pkg/Thing a\nThing b\n"
        "geometry_msgs/Pose[3] poses\nuint8 MODE=1\n---\nbool ok\n"
    )
    converted, deps = ros2_definition(text, "my_pkg")
    assert converted.splitlines() == [
        "std_msgs/Header header  # stamp",
        "builtin_interfaces/Time[] stamps",
        "builtin_interfaces/Duration wait",
        "Thing a",
        "Thing b",
        "geometry_msgs/Pose[3] poses",
        "uint8 MODE=1",
        "---",
        "bool ok",
    ]
    assert deps == {"std_msgs", "builtin_interfaces", "geometry_msgs"}


def test_shipped_moveit_depends_on_what_it_uses() -> None:
    pkg = load_package(SHIPPED_DEFINITIONS / "moveit_msgs")
    assert "object_recognition_msgs" in pkg.dependencies
    assert "trajectory_msgs" in pkg.dependencies
    assert "moveit_msgs" not in pkg.dependencies


def test_shipped_control_msgs_builds_its_ros2_variants() -> None:
    pkg = load_package(SHIPPED_DEFINITIONS / "control_msgs")
    assert sorted(pkg.files) == [
        "action/FollowJointTrajectory.action",
        "action/GripperCommand.action",
        "msg/GripperCommand.msg",
        "msg/JointComponentTolerance.msg",
        "msg/JointTolerance.msg",
        "msg/JointTrajectoryControllerState.msg",
    ]
    assert (
        "trajectory_msgs/MultiDOFJointTrajectory multi_dof_trajectory"
        in (pkg.files["action/FollowJointTrajectory.action"])
    )
    assert "JointTrajectoryPoint reference" in pkg.files["msg/JointTrajectoryControllerState.msg"]


JAZZY_TYPE_HASHES = {
    "action/FollowJointTrajectory": (
        "RIHS01_738ebcb7a2d7cfa42f9f1001cc99ce3a4383d1cfe508015d9be8485e4b1c66f6"
    ),
    "action/GripperCommand": (
        "RIHS01_e17c0e644eccf14bea84a0a93e0977182872c2eb7873ca6694900059b46dbc84"
    ),
    "msg/JointTrajectoryControllerState": (
        "RIHS01_51d8dd89cc624cbe9daaeeb4d80d6de9b86168ffdc3be41fefc0953e3c26e480"
    ),
}
"""control_msgs 5.8.0's (Jazzy) RIHS01 hashes, as rosidl_generator_type_description 4.6.6
computes them from that release's files; an action's covers its goal, result, feedback and
services."""


@pytest.mark.ros2
@pytest.mark.parametrize(("name", "expected"), sorted(JAZZY_TYPE_HASHES.items()))
def test_shipped_control_msgs_has_jazzys_type_hashes(name: str, expected: str) -> None:
    """What `make ros2` built, as rclpy announces it: a client built against the real
    control_msgs (MoveIt 2) sees the same types."""
    share = require_ros2().parent.parent / "share" / "control_msgs"
    description = json.loads((share / f"{name}.json").read_text())
    assert description["type_hashes"][0] == {
        "type_name": f"control_msgs/{name}",
        "hash_string": expected,
    }, "stale build? run `make ros2`"


def test_shipped_vision_msgs_builds_its_4x_layouts() -> None:
    """ROS 2 gets vision_msgs 4.x (class names, vision_msgs/Pose2D centres) from the ros2/
    folder, not the noetic files that ROS 1 uses."""
    pkg = load_package(SHIPPED_DEFINITIONS / "vision_msgs")
    assert sorted(pkg.files) == [
        f"msg/{name}.msg"
        for name in (
            "BoundingBox2D",
            "Detection2D",
            "Detection2DArray",
            "ObjectHypothesis",
            "ObjectHypothesisWithPose",
            "Point2D",
            "Pose2D",
        )
    ]
    assert "string class_id" in pkg.files["msg/ObjectHypothesis.msg"]
    assert "string id" in pkg.files["msg/Detection2D.msg"]
    assert "sensor_msgs" not in pkg.dependencies  # noetic's source_img is ROS 1's only


VISION_MSGS_TYPE_HASHES = {
    "BoundingBox2D": "RIHS01_008eacbb0cf8f26e83795547bed013eec3675485ef386ec056d80eaaf1c1ce2f",
    "Detection2D": "RIHS01_0d12b69df5c593b3455b7346fac8205437a7d4bcb09b9e0e0b2dde787ded38ea",
    "Detection2DArray": "RIHS01_214274120007f4a683866481336b70310268cfa107aebe9d594a6acf75bda968",
    "ObjectHypothesis": "RIHS01_51da43cec11c01957a64d1e05a24acd18aae7745ec30b74348ad5f6d634f7f90",
    "ObjectHypothesisWithPose": (
        "RIHS01_41c12344c0396c48b81df12467c192d99b2a0eb1463c5c37194e4223251c80bc"
    ),
    "Point2D": "RIHS01_eab0e83f44ab4de92ceaf76dd7d0e7638f2bdd1d16ffbe16c7a136c48e407247",
    "Pose2D": "RIHS01_b0b5d1d7b4c20dd4fcde3ed1d4b289a919290572007d67a97043814db25d3648",
}
"""vision_msgs 4.1.1's RIHS01 hashes, as rosidl_generator_type_description 4.6.6 computes
them from that release's files (against the venv's Jazzy std_msgs and geometry_msgs)."""


@pytest.mark.ros2
@pytest.mark.parametrize(("name", "expected"), sorted(VISION_MSGS_TYPE_HASHES.items()))
def test_shipped_vision_msgs_has_4x_type_hashes(name: str, expected: str) -> None:
    """What `make ros2` built: a detector built against the real vision_msgs sees the
    same types as simbridge's live-label detections."""
    share = require_ros2().parent.parent / "share" / "vision_msgs"
    description = json.loads((share / "msg" / f"{name}.json").read_text())
    assert description["type_hashes"][0] == {
        "type_name": f"vision_msgs/msg/{name}",
        "hash_string": expected,
    }, "stale build? run `make ros2`"


def test_a_directory_without_interfaces_is_refused(tmp_path: Path) -> None:
    with pytest.raises(InterfaceBuildError, match="neither an interface package"):
        build_packages([tmp_path], tmp_path)


def test_missing_tools_are_named(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "pkg" / "msg").mkdir(parents=True)
    (tmp_path / "pkg" / "msg" / "A.msg").write_text("int32 a\n")
    monkeypatch.setenv("PATH", str(tmp_path / "nothing"))
    monkeypatch.delenv("CC", raising=False)
    monkeypatch.delenv("CXX", raising=False)
    with pytest.raises(InterfaceBuildError, match="needs cmake, ninja, a C compiler"):
        build_packages([tmp_path / "pkg"], tmp_path / "venv", progress=lambda _: None)


@pytest.mark.ros2
@pytest.mark.timeout(900)
def test_msg_build_makes_a_user_package_importable_in_rclpy(tmp_path: Path) -> None:
    python = require_ros2()
    pkg = tmp_path / "sb_test_msgs"
    (pkg / "msg").mkdir(parents=True)
    (pkg / "srv").mkdir()
    (pkg / "msg" / "Reading.msg").write_text(
        textwrap.dedent("""\
        # a ROS 1 style definition
        Header header
        time taken
        float64[] values
        geometry_msgs/Point where
        """)
    )
    (pkg / "srv" / "Ask.srv").write_text("Reading reading\n---\nbool ok\n")
    venv = python.parent.parent
    build = [sys.executable, "-m", "simbridge.cli", "msg", "build", str(pkg), "--venv", str(venv)]
    first = subprocess.run(build, capture_output=True, text=True, timeout=850, check=False)
    assert first.returncode == 0, first.stdout + first.stderr
    again = subprocess.run(build, capture_output=True, text=True, timeout=60, check=True)
    assert "sb_test_msgs: up to date" in again.stdout
    check = textwrap.dedent("""\
        from rclpy.serialization import deserialize_message, serialize_message
        from sb_test_msgs.msg import Reading
        from sb_test_msgs.srv import Ask
        r = Reading(values=[1.5, 2.5])
        r.header.frame_id = "x"
        r.taken.sec = 7
        r.where.z = 3.0
        back = deserialize_message(serialize_message(r), Reading)
        print(back.header.frame_id, back.taken.sec, list(back.values), back.where.z)
        print(Ask.Response().ok)
        """)
    out = subprocess.run(
        [str(python), "-c", check],
        env=child_env(),
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert out.stdout.split() == ["x", "7", "[1.5,", "2.5]", "3.0", "False"], out.stderr
