"""ROS 2 mode of the message layer: Jazzy layouts, rosidl names, CDR bytes checked by hand."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pytest

from simbridge.errors import UnknownMessageTypeError
from simbridge.messages import (
    ROS2_STORE,
    SHIPPED_DEFINITIONS,
    MessageRegistry,
    default_registry,
    parse_type_name,
    ros2_registry,
)

CDR_LE = b"\x00\x01\x00\x00"


@pytest.fixture(scope="module")
def ros2() -> MessageRegistry:
    return ros2_registry()


def test_ros2_registry_is_shared_and_speaks_cdr(ros2: MessageRegistry) -> None:
    assert ros2 is ros2_registry()
    assert ros2 is not default_registry()
    assert (ros2.protocol, ros2.wire_format) == ("ROS2", "cdr")
    assert (default_registry().protocol, default_registry().wire_format) == ("ROS1", "ros1")


def test_header_has_no_seq_and_time_is_int32_uint32(ros2: MessageRegistry) -> None:
    assert [f.name for f in ros2.schema("std_msgs/Header").fields] == ["stamp", "frame_id"]
    time_fields = ros2.schema("builtin_interfaces/Time").fields
    assert [(f.name, f.type) for f in time_fields] == [("sec", "int32"), ("nanosec", "uint32")]
    header = ros2.new("std_msgs/Header", stamp={"sec": 1, "nanosec": 2}, frame_id="a")
    # sec, nanosec, frame_id length (NUL counted), "a\0"
    assert ros2.encode(header) == CDR_LE + bytes.fromhex("01000000 02000000 02000000 6100")
    before_epoch = ros2.msg_class("builtin_interfaces/Time")(sec=-1, nanosec=4_000_000_000)
    assert ros2.encode(before_epoch) == CDR_LE + bytes.fromhex("ffffffff 00286bee")


def test_clock_bytes(ros2: MessageRegistry) -> None:
    clock = ros2.new("rosgraph_msgs/Clock", clock={"sec": 7, "nanosec": 500})
    assert ros2.encode(clock) == CDR_LE + struct.pack("<iI", 7, 500)
    assert ros2.to_dict(ros2.decode(ros2.encode(clock), "rosgraph_msgs/Clock")) == {
        "clock": {"sec": 7, "nanosec": 500}
    }


def test_camera_info_d_k_r_p_bytes(ros2: MessageRegistry) -> None:
    names = [f.name for f in ros2.schema("sensor_msgs/CameraInfo").fields]
    assert names[4:8] == ["d", "k", "r", "p"]
    k, r, p = np.arange(9.0), np.eye(3).ravel(), np.arange(12.0) / 2
    info = ros2.new(
        "sensor_msgs/CameraInfo",
        header={"frame_id": "c"},
        height=2,
        width=3,
        distortion_model="plumb_bob",
        d=[0.25],
        k=k,
        r=r,
        p=p,
        roi={"do_rectify": True},
    )
    expected = (
        struct.pack("<iII", 0, 0, 2) + b"c\x00"  # stamp, frame_id length + text
        + b"\x00\x00"  # pad to 4
        + struct.pack("<II", 2, 3)  # height, width
        + struct.pack("<I", 10) + b"plumb_bob\x00"  # distortion_model
        + b"\x00\x00"  # pad to 4 (offset 40)
        + struct.pack("<I", 1)  # d: sequence length
        + b"\x00" * 4  # pad to 8 (offset 48)
        + struct.pack("<d", 0.25)
        + k.astype("<f8").tobytes() + r.astype("<f8").tobytes() + p.astype("<f8").tobytes()
        + struct.pack("<II", 0, 0)  # binning
        + struct.pack("<IIII?", 0, 0, 0, 0, True)  # roi
    )  # fmt: skip
    assert len(expected) == 321
    assert ros2.encode(info) == CDR_LE + expected
    back = ros2.decode(CDR_LE + expected, "sensor_msgs/CameraInfo")
    assert back.k.tolist() == k.tolist()
    assert back.p.tolist() == p.tolist()
    assert back.header.frame_id == "c"
    assert back.roi.do_rectify


def test_tf_message_bytes_with_shipped_tf2_msgs(ros2: MessageRegistry) -> None:
    tf = ros2.from_yaml(
        "tf2_msgs/TFMessage",
        "transforms: [{header: {stamp: {sec: 3, nanosec: 4}, frame_id: world},"
        " child_frame_id: base, transform: {translation: {x: 1.0}, rotation: {w: 1.0}}}]",
    )
    expected = (
        struct.pack("<IiII", 1, 3, 4, 6) + b"world\x00"  # one transform; header
        + b"\x00\x00"  # pad to 4 (offset 24)
        + struct.pack("<I", 5) + b"base\x00"  # child_frame_id
        + b"\x00" * 7  # pad to 8 (offset 40)
        + struct.pack("<7d", 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)
    )  # fmt: skip
    assert ros2.encode(tf) == CDR_LE + expected


def test_every_shipped_package_but_roscpp_works_in_ros2_mode(ros2: MessageRegistry) -> None:
    shipped = {p.name for p in SHIPPED_DEFINITIONS.iterdir() if p.is_dir()}
    loaded = {n.partition("/")[0] for n in [*ros2.names(), *ros2.service_names()]}
    assert shipped - loaded == {"roscpp"}  # roscpp/Logger exists in ROS 1 only
    request = ros2.new(
        "niryo_moveit/MoverServiceRequest",
        joints_input={"joints": [0.1] * 6},
        pick_pose={"position": {"x": 0.3}},
    )
    back = ros2.decode(ros2.encode(request), "niryo_moveit/srv/MoverService_Request")
    assert ros2.to_dict(back) == ros2.to_dict(request)
    response = ros2.new("niryo_moveit/MoverServiceResponse", trajectories=[{}])
    trajectory = response.trajectories[0].joint_trajectory
    assert not hasattr(trajectory.header, "seq")


@pytest.mark.parametrize(
    ("name", "ros2_name"),
    [
        ("sensor_msgs/Image", "sensor_msgs/msg/Image"),
        ("sensor_msgs/msg/Image", "sensor_msgs/msg/Image"),
        ("std_srvs/SetBool", "std_srvs/srv/SetBool"),
        ("std_srvs/SetBoolRequest", "std_srvs/srv/SetBool_Request"),
        ("niryo_moveit/srv/MoverService_Response", "niryo_moveit/srv/MoverService_Response"),
        ("tf2_msgs/LookupTransformGoal", "tf2_msgs/action/LookupTransform_Goal"),
        ("tf2_msgs/action/LookupTransform_SendGoal", "tf2_msgs/action/LookupTransform_SendGoal"),
        (
            "tf2_msgs/LookupTransformGetResultResponse",
            "tf2_msgs/action/LookupTransform_GetResult_Response",
        ),
        (
            "tf2_msgs/LookupTransformFeedbackMessage",
            "tf2_msgs/action/LookupTransform_FeedbackMessage",
        ),
    ],
)
def test_names_both_ways(ros2: MessageRegistry, name: str, ros2_name: str) -> None:
    assert ros2.ros2_name(name) == ros2_name
    parsed = parse_type_name(ros2_name)
    assert parsed is not None
    assert ros2.ros2_name(parsed.canonical) == ros2_name


def test_unknown_name_is_named(ros2: MessageRegistry) -> None:
    with pytest.raises(UnknownMessageTypeError, match="sensor_msgs/Imag"):
        ros2.ros2_name("sensor_msgs/Imag")


def test_user_package_in_ros2_layout(tmp_path: Path) -> None:
    pkg = tmp_path / "my_robot_msgs"
    (pkg / "msg").mkdir(parents=True)
    (pkg / "srv").mkdir()
    (pkg / "action").mkdir()
    (pkg / "msg" / "Battery.msg").write_text("std_msgs/Header header\nfloat32 voltage\n")
    (pkg / "srv" / "Dock.srv").write_text("string station\n---\nbool ok\n")
    (pkg / "action" / "Drive.action").write_text(
        "float64 distance\n---\nfloat64 travelled\n---\nfloat64 remaining\n"
    )
    reg = MessageRegistry(store=ROS2_STORE, shipped=False)
    reg.load_packages(tmp_path)
    battery = reg.new("my_robot_msgs/msg/Battery", voltage=12.5)
    assert reg.encode(battery) == CDR_LE + struct.pack("<iII", 0, 0, 1) + b"\x00" + (
        b"\x00\x00\x00" + struct.pack("<f", 12.5)
    )
    assert reg.service("my_robot_msgs/srv/Dock").request == "my_robot_msgs/DockRequest"
    # rosidl's action expansion: SendGoal / GetResult services and the feedback message.
    send = reg.service("my_robot_msgs/action/Drive_SendGoal")
    assert [f.name for f in reg.schema(send.request).fields] == ["goal_id", "goal"]
    assert [f.name for f in reg.schema(send.response).fields] == ["accepted", "stamp"]
    result = reg.service("my_robot_msgs/action/Drive_GetResult")
    assert [f.name for f in reg.schema(result.response).fields] == ["status", "result"]
    feedback = reg.schema("my_robot_msgs/action/Drive_FeedbackMessage")
    assert [f.type for f in feedback.fields] == [
        "unique_identifier_msgs/UUID",
        "my_robot_msgs/DriveFeedback",
    ]
    assert not reg.has("my_robot_msgs/DriveActionGoal")  # the ROS 1 (actionlib) expansion
    assert reg.ros2_name("my_robot_msgs/DriveSendGoalRequest") == (
        "my_robot_msgs/action/Drive_SendGoal_Request"
    )


def test_a_ros2_folder_holds_the_ros2_variants(tmp_path: Path) -> None:
    """`<pkg>/ros2/` files replace the package's own in ROS 2 mode and add ROS 2-only types;
    ROS 1 mode never reads them."""
    pkg = tmp_path / "arm_msgs"
    for folder in ("msg", "action", "ros2/msg", "ros2/action"):
        (pkg / folder).mkdir(parents=True)
    (pkg / "msg" / "Grip.msg").write_text("float64 width\n")
    (pkg / "msg" / "State.msg").write_text("float64 desired\n")
    (pkg / "ros2" / "msg" / "State.msg").write_text("float64 reference\nExtra extra\n")
    (pkg / "ros2" / "msg" / "Extra.msg").write_text("uint16 axis\n")
    (pkg / "action" / "Move.action").write_text("float64 to\n---\n---\n")
    (pkg / "ros2" / "action" / "Move.action").write_text("float64 to\nuint16 axis\n---\n---\n")
    ros1 = MessageRegistry(shipped=False)
    ros1.load_packages(tmp_path)
    ros2 = MessageRegistry(store=ROS2_STORE, shipped=False)
    ros2.load_packages(tmp_path)

    def fields(reg: MessageRegistry, name: str) -> list[str]:
        return [f.name for f in reg.schema(name).fields]

    assert fields(ros1, "arm_msgs/State") == ["desired"]
    assert fields(ros2, "arm_msgs/State") == ["reference", "extra"]
    assert fields(ros1, "arm_msgs/MoveGoal") == ["to"]
    assert fields(ros2, "arm_msgs/MoveGoal") == ["to", "axis"]
    assert (ros1.has("arm_msgs/Extra"), ros2.has("arm_msgs/Extra")) == (False, True)
    assert fields(ros1, "arm_msgs/Grip") == fields(ros2, "arm_msgs/Grip") == ["width"]


def test_translator_ros1_to_ros2(ros2: MessageRegistry) -> None:
    from simbridge.messages import Translator

    ros1 = default_registry()
    translate = Translator(ros1, ros2).translate
    info = ros1.new(
        "sensor_msgs/CameraInfo",
        header={"seq": 9, "stamp": {"secs": 3, "nsecs": 4}, "frame_id": "cam"},
        D=[0.1, 0.2],
        K=np.arange(9.0),
        P=np.arange(12.0),
    )
    out = translate(info)
    assert type(out) is ros2.msg_class("sensor_msgs/CameraInfo")
    assert out.d.tolist() == [0.1, 0.2]
    assert out.k.tolist() == list(range(9))
    assert out.p.tolist() == list(range(12))
    assert (out.header.stamp.sec, out.header.stamp.nanosec, out.header.frame_id) == (3, 4, "cam")
    assert not hasattr(out.header, "seq")
    image = ros1.new("sensor_msgs/Image", data=np.zeros(12, np.uint8), height=2, width=2)
    assert translate(image).data is image.data  # pixels are shared, not copied
    twist = ros1.new("geometry_msgs/Twist", linear={"x": 1.0})
    assert translate(twist) is twist  # same layout: passed through
    assert ros2.encode(twist) == ros2.encode(ros2.new("geometry_msgs/Twist", linear={"x": 1.0}))


def test_cdr_from_rclpy_may_end_in_unused_bytes(ros2: MessageRegistry) -> None:
    """rmw sizes serialized messages by an upper bound: the bytes past the message (as
    rclpy returned them for a MoverService response, garbage included) are ignored."""
    response = ros2.new(
        "niryo_moveit/MoverServiceResponse",
        trajectories=[
            {"joint_trajectory": {"joint_names": ["a"], "points": [{"positions": [1.0]}]}}
        ],
    )
    wire = ros2.encode(response) + bytes.fromhex("b01eca457e7f0000f01eca45")
    back = ros2.decode(wire, "niryo_moveit/MoverServiceResponse")
    assert ros2.to_dict(back) == ros2.to_dict(response)
