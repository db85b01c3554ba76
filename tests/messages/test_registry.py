"""Registry lookups, shipped definitions, user packages and `rosmsg show` output."""

from __future__ import annotations

from pathlib import Path

import pytest

from simbridge.errors import MessageError, UnknownMessageTypeError
from simbridge.messages import SHIPPED_DEFINITIONS, MessageRegistry


def test_resolve_accepts_ros1_and_ros2_spellings(registry: MessageRegistry) -> None:
    assert registry.resolve("geometry_msgs/Twist") == "geometry_msgs/Twist"
    assert registry.resolve("geometry_msgs/msg/Twist") == "geometry_msgs/Twist"
    assert registry.resolve("Header") == "std_msgs/Header"
    assert registry.resolve("std_srvs/srv/SetBool_Request") == "std_srvs/SetBoolRequest"
    assert registry.has("sensor_msgs/Image")
    assert not registry.has("sensor_msgs/Imagee")
    assert not registry.has("std_srvs/SetBool")  # a service, not a message
    assert registry.has_service("std_srvs/srv/SetBool")


def test_unknown_type_names_close_matches(registry: MessageRegistry) -> None:
    with pytest.raises(UnknownMessageTypeError) as info:
        registry.resolve("geometry_msgs/Twits")
    text = str(info.value)
    assert "geometry_msgs/Twits" in text
    assert "geometry_msgs/Twist" in text
    assert isinstance(info.value, KeyError)
    with pytest.raises(UnknownMessageTypeError, match="std_srvs/SetBool"):
        registry.service("std_srvs/SetBol")


def test_golden_md5s(registry: MessageRegistry) -> None:
    assert registry.md5("geometry_msgs/Twist") == "9f195f881246fdfa2798d1d3eebca84a"
    assert registry.md5("sensor_msgs/Image") == "060021388200f6f0f447d0fcd9c64743"
    assert registry.md5("std_msgs/Header") == "2176decaecbce78abc3b96ef049fabed"
    assert registry.md5("std_msgs/msg/Header") == "2176decaecbce78abc3b96ef049fabed"
    assert registry.md5("std_srvs/SetBool") == "09fb03525b03e7ea1fd3992bafd87e16"


# md5sums published by genmsg-generated code for moveit_msgs 0.11 (noetic),
# object_recognition_msgs and the Unity pick-and-place tutorial's niryo_moveit.
SHIPPED_GOLDEN = {
    "moveit_msgs/RobotTrajectory": "dfa9556423d709a3729bcef664bddf67",
    "moveit_msgs/RobotState": "968156f4aa4cb4018f1f2293eebcea8f",
    "moveit_msgs/CollisionObject": "dbba710596087da521c07564160dfccb",
    "moveit_msgs/AttachedCollisionObject": "30199ef516f64c8bc1edb1084ce4584e",
    "moveit_msgs/DisplayTrajectory": "41936b74e168ba754279ae683ce3f121",
    "object_recognition_msgs/ObjectType": "ac757ec5be1998b0167e7efcda79e3cf",
    "niryo_moveit/NiryoMoveitJoints": "3894bb7ef9fbb4e54ec5ad55d9a45d5d",
    "niryo_moveit/MoverServiceResponse": "c2b40c48066c9f23bf2c1a49578cb21d",
}


@pytest.mark.parametrize(("name", "md5"), SHIPPED_GOLDEN.items())
def test_shipped_definitions_match_published_md5s(
    registry: MessageRegistry, name: str, md5: str
) -> None:
    assert registry.md5(name) == md5


def test_niryo_mover_service_layout(registry: MessageRegistry) -> None:
    info = registry.service("niryo_moveit/MoverService")
    assert (info.request, info.response) == (
        "niryo_moveit/MoverServiceRequest",
        "niryo_moveit/MoverServiceResponse",
    )
    request = registry.schema(info.request)
    assert [(f.name, f.type) for f in request.fields] == [
        ("joints_input", "niryo_moveit/NiryoMoveitJoints"),
        ("pick_pose", "geometry_msgs/Pose"),
        ("place_pose", "geometry_msgs/Pose"),
    ]
    response = registry.schema(info.response).field("trajectories")
    assert (response.type, response.array) == ("moveit_msgs/RobotTrajectory", "sequence")


def test_service_md5_rule_against_genmsg_output(tmp_path: Path) -> None:
    """The older tutorial layout (six float64 fields) with genmsg's published md5s."""
    package = tmp_path / "niryo_moveit"
    (package / "msg").mkdir(parents=True)
    (package / "srv").mkdir()
    joints = "".join(f"float64 joint_0{i}\n" for i in range(6))
    (package / "msg" / "NiryoMoveitJoints.msg").write_text(
        joints + "geometry_msgs/Pose pick_pose\ngeometry_msgs/Pose place_pose\n"
    )
    (package / "srv" / "MoverService.srv").write_text(
        "NiryoMoveitJoints joints_input\ngeometry_msgs/Pose pick_pose\n"
        "geometry_msgs/Pose place_pose\n---\nmoveit_msgs/RobotTrajectory[] trajectories\n"
    )
    registry = MessageRegistry(shipped=False)
    registry.load_packages(
        SHIPPED_DEFINITIONS / "moveit_msgs", SHIPPED_DEFINITIONS / "object_recognition_msgs"
    )
    assert registry.load_packages(tmp_path) == [
        "niryo_moveit/MoverServiceRequest",
        "niryo_moveit/MoverServiceResponse",
        "niryo_moveit/NiryoMoveitJoints",
    ]
    assert registry.md5("niryo_moveit/MoverServiceRequest") == "375ea90ec3b506491b1fc61b79625a40"
    assert registry.md5("niryo_moveit/MoverService") == "5fbee572b5171ffedfc368176e058405"


def test_action_expansion_and_package_dir(fresh_registry: MessageRegistry, tmp_path: Path) -> None:
    package = tmp_path / "demo_msgs"
    (package / "action").mkdir(parents=True)
    (package / "action" / "Count.action").write_text(
        "int32 goal  # count to this\n---\nint32 result\n---\nint32 feedback\n"
    )
    added = fresh_registry.load_packages(package)
    assert added == sorted(
        f"demo_msgs/Count{suffix}"
        for suffix in (
            "Goal",
            "Result",
            "Feedback",
            "Action",
            "ActionGoal",
            "ActionResult",
            "ActionFeedback",
        )
    )
    goal = fresh_registry.schema("demo_msgs/CountActionGoal")
    assert [(f.name, f.type) for f in goal.fields] == [
        ("header", "std_msgs/Header"),
        ("goal_id", "actionlib_msgs/GoalID"),
        ("goal", "demo_msgs/CountGoal"),
    ]
    action = fresh_registry.new("demo_msgs/CountAction")
    action.action_goal.goal.goal = 5
    wire = fresh_registry.encode(action)
    assert fresh_registry.decode(wire, "demo_msgs/CountAction").action_goal.goal.goal == 5
    # Same fields as actionlib's Test.action (generated by genmsg, in the noetic store):
    # md5s ignore package names, so all seven expanded types must hash alike.
    for name in added:
        twin = name.replace("demo_msgs/Count", "actionlib/Test")
        assert fresh_registry.md5(name) == fresh_registry.md5(twin), name


def test_dir_of_packages_with_msg_and_srv(fresh_registry: MessageRegistry, tmp_path: Path) -> None:
    (tmp_path / "alpha_msgs" / "msg").mkdir(parents=True)
    (tmp_path / "alpha_msgs" / "msg" / "Point2.msg").write_text("float32 x\nfloat32 y\n")
    (tmp_path / "beta_msgs" / "srv").mkdir(parents=True)
    (tmp_path / "beta_msgs" / "srv" / "Move.srv").write_text(
        "alpha_msgs/Point2 target\n---\nbool ok\n"
    )
    (tmp_path / "not_a_package").mkdir()
    added = fresh_registry.load_packages(tmp_path)
    assert added == ["alpha_msgs/Point2", "beta_msgs/MoveRequest", "beta_msgs/MoveResponse"]
    info = fresh_registry.service("beta_msgs/srv/Move")
    assert info.request == "beta_msgs/MoveRequest"
    # genmsg: md5 over request text + response text; Point2's md5 replaces its name.
    import hashlib

    point = hashlib.md5(b"float32 x\nfloat32 y").hexdigest()
    expected = hashlib.md5(f"{point} target".encode() + b"bool ok").hexdigest()
    assert info.md5 == expected
    assert fresh_registry.md5("beta_msgs/Move") == expected


def test_constant_md5_uses_source_text(fresh_registry: MessageRegistry) -> None:
    import hashlib

    fresh_registry.add_message("demo_msgs/Consts", "float64 HALF = 0.50 # note\nstring S= a#b \n")
    expected = hashlib.md5(b"float64 HALF=0.50\nstring S=a#b").hexdigest()
    assert fresh_registry.md5("demo_msgs/Consts") == expected


def test_bad_definitions_are_rejected_whole(fresh_registry: MessageRegistry) -> None:
    with pytest.raises(MessageError, match=r"demo_msgs/Bad\.pose uses unknown message type"):
        fresh_registry.add_message("demo_msgs/Bad", "geometry_msgs/Poze pose\n")
    assert not fresh_registry.has("demo_msgs/Bad")
    with pytest.raises(MessageError, match="invalid definition of demo_msgs/Worse, line 2"):
        fresh_registry.add_message("demo_msgs/Worse", "# ok\nfloat64 x 1.5\n")
    with pytest.raises(MessageError, match="invalid definition of demo_msgs/Worst"):
        fresh_registry.add_message("demo_msgs/Worst", "float64[x] values\n")
    with pytest.raises(MessageError, match="different definition"):
        fresh_registry.add_message("std_msgs/String", "int32 data\n")
    with pytest.raises(MessageError, match="separator"):
        fresh_registry.add_service("demo_msgs/NoSep", "int32 a\n")
    with pytest.raises(MessageError, match="invalid type name"):
        fresh_registry.add_message("NoPackage", "int32 a\n")


def test_load_errors_name_the_path(fresh_registry: MessageRegistry, tmp_path: Path) -> None:
    with pytest.raises(MessageError, match="not a directory"):
        fresh_registry.load_packages(tmp_path / "missing")
    with pytest.raises(MessageError, match="no ROS package"):
        fresh_registry.load_packages(tmp_path)


def test_definition_is_genpy_full_text(registry: MessageRegistry) -> None:
    text = registry.definition("niryo_moveit/NiryoTrajectory")
    sections = text.split("=" * 80 + "\n")
    source = (SHIPPED_DEFINITIONS / "niryo_moveit/msg/NiryoTrajectory.msg").read_text()
    assert sections[0] == source + "\n"
    headers = [s.splitlines()[0] for s in sections[1:]]
    assert headers == [
        "MSG: moveit_msgs/RobotTrajectory",
        "MSG: trajectory_msgs/JointTrajectory",
        "MSG: std_msgs/Header",
        "MSG: trajectory_msgs/JointTrajectoryPoint",
        "MSG: trajectory_msgs/MultiDOFJointTrajectory",
        "MSG: trajectory_msgs/MultiDOFJointTrajectoryPoint",
        "MSG: geometry_msgs/Transform",
        "MSG: geometry_msgs/Vector3",
        "MSG: geometry_msgs/Quaternion",
        "MSG: geometry_msgs/Twist",
    ]
    assert registry.definition("std_msgs/Empty") == ""
    assert registry.definition("std_msgs/String") == "string data\n"


def test_show_matches_rosmsg_layout(registry: MessageRegistry) -> None:
    assert registry.show("geometry_msgs/Twist") == (
        "geometry_msgs/Vector3 linear\n  float64 x\n  float64 y\n  float64 z\n"
        "geometry_msgs/Vector3 angular\n  float64 x\n  float64 y\n  float64 z\n"
    )
    assert registry.show("std_srvs/SetBool") == "bool data\n---\nbool success\nstring message\n"
    error = registry.show("tf2_msgs/TF2Error")
    assert error.startswith("uint8 NO_ERROR=0\nuint8 LOOKUP_ERROR=1\n")
    assert error.endswith("uint8 error\nstring error_string\n")
    imu = registry.show("sensor_msgs/Imu").splitlines()
    assert imu[:5] == [
        "std_msgs/Header header",
        "  uint32 seq",
        "  time stamp",
        "  string frame_id",
        "geometry_msgs/Quaternion orientation",
    ]
    assert "float64[9] orientation_covariance" in imu


def test_module_functions_use_default_registry() -> None:
    from simbridge.messages import md5, show

    assert md5("std_srvs/Trigger") == "937c9679a518e3a18d831e57125ea522"
    assert show("std_msgs/String") == "string data\n"


def test_names_lists(registry: MessageRegistry) -> None:
    names = registry.names()
    assert names == sorted(names)
    assert {"geometry_msgs/Twist", "moveit_msgs/RobotTrajectory", "tf2_msgs/TFMessage"} <= set(
        names
    )
    assert "builtin_interfaces/Time" not in names
    assert {"std_srvs/SetBool", "niryo_moveit/MoverService"} <= set(registry.service_names())
