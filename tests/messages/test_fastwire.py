"""The precompiled sim-state serializers write exactly the generic codec's bytes."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from simbridge.messages import MessageRegistry, WireFormat, default_registry, ros2_registry
from simbridge.messages.fastwire import ClockWriter, JointStateWriter, TFWriter

COMBOS = [
    pytest.param("ROS1", "ros1", id="ros1-layouts-ros1"),
    pytest.param("ROS1", "cdr", id="ros1-layouts-cdr"),
    pytest.param("ROS2", "cdr", id="ros2-layouts-cdr"),
    pytest.param("ROS2", "ros1", id="ros2-layouts-ros1"),
]

names = st.text(st.characters(codec="utf-8", blacklist_characters="\x00"), max_size=12)
floats = st.floats(allow_nan=False, width=64)
secs = st.integers(0, 2**31 - 1)
nsecs = st.integers(0, 10**9 - 1)


def _registry(generation: str) -> MessageRegistry:
    return default_registry() if generation == "ROS1" else ros2_registry()


def _time(reg: MessageRegistry, sec: int, nanosec: int) -> Any:
    return reg.msg_class("time")(sec=sec, nanosec=nanosec)


def _header(reg: MessageRegistry, sec: int, nanosec: int, frame: str) -> Any:
    seq = {"seq": 0} if reg.protocol == "ROS1" else {}
    return reg.msg_class("std_msgs/Header")(stamp=_time(reg, sec, nanosec), frame_id=frame, **seq)


@pytest.mark.parametrize(("generation", "fmt"), COMBOS)
@settings(max_examples=60, deadline=None)
@given(
    data=st.lists(st.tuples(names, floats, floats, floats), max_size=9),
    frame=names,
    stamp=st.tuples(secs, nsecs),
)
def test_joint_state_bytes(
    generation: str,
    fmt: WireFormat,
    data: list[tuple[str, float, float, float]],
    frame: str,
    stamp: tuple[int, int],
) -> None:
    reg = _registry(generation)
    sec, nanosec = stamp
    joint_names = [d[0] for d in data]
    pos, vel, eff = [d[1] for d in data], [d[2] for d in data], [d[3] for d in data]
    msg = reg.msg_class("sensor_msgs/JointState")(
        header=_header(reg, sec, nanosec, frame),
        name=joint_names,
        position=np.array(pos, dtype=np.float64),
        velocity=np.array(vel, dtype=np.float64),
        effort=np.array(eff, dtype=np.float64),
    )
    writer = JointStateWriter(fmt, joint_names, frame, seq=reg.protocol == "ROS1")
    expected = reg.codec("sensor_msgs/JointState").encode(msg, fmt)
    assert writer.encode(sec, nanosec, pos, vel, eff) == expected
    # The buffer is reused: a second message with other values is right too.
    assert writer.encode(0, 1, [0.5] * len(pos), vel, eff) == reg.codec(
        "sensor_msgs/JointState"
    ).encode(
        reg.msg_class("sensor_msgs/JointState")(
            header=_header(reg, 0, 1, frame),
            name=joint_names,
            position=np.full(len(pos), 0.5),
            velocity=np.array(vel, dtype=np.float64),
            effort=np.array(eff, dtype=np.float64),
        ),
        fmt,
    )


@pytest.mark.parametrize(("generation", "fmt"), COMBOS)
@settings(max_examples=60, deadline=None)
@given(
    edges=st.lists(st.tuples(names, names, st.tuples(*[floats] * 7)), max_size=8),
    sec=secs,
    nanosec=nsecs,
)
def test_tf_bytes(
    generation: str,
    fmt: WireFormat,
    edges: list[tuple[str, str, tuple[float, ...]]],
    sec: int,
    nanosec: int,
) -> None:
    reg = _registry(generation)
    vector, quat = reg.msg_class("geometry_msgs/Vector3"), reg.msg_class("geometry_msgs/Quaternion")
    transform = reg.msg_class("geometry_msgs/Transform")
    stamped = reg.msg_class("geometry_msgs/TransformStamped")
    msg = reg.msg_class("tf2_msgs/TFMessage")(
        transforms=[
            stamped(
                header=_header(reg, sec, nanosec, parent),
                child_frame_id=child,
                transform=transform(
                    translation=vector(x=p[0], y=p[1], z=p[2]),
                    rotation=quat(x=p[3], y=p[4], z=p[5], w=p[6]),
                ),
            )
            for parent, child, p in edges
        ]
    )
    writer = TFWriter(fmt, [(p, c) for p, c, _ in edges], seq=reg.protocol == "ROS1")
    got = writer.encode(sec, nanosec, [p for _, _, p in edges])
    assert got == reg.codec("tf2_msgs/TFMessage").encode(msg, fmt)


@pytest.mark.parametrize(("generation", "fmt"), COMBOS)
@settings(max_examples=60, deadline=None)
@given(sec=secs, nanosec=nsecs)
def test_clock_bytes(generation: str, fmt: WireFormat, sec: int, nanosec: int) -> None:
    reg = _registry(generation)
    msg = reg.msg_class("rosgraph_msgs/Clock")(clock=_time(reg, sec, nanosec))
    writer = ClockWriter(fmt)
    assert writer.encode(sec, nanosec) == reg.codec("rosgraph_msgs/Clock").encode(msg, fmt)


def test_ros1_stamp_beyond_2038() -> None:
    """ROS 1 `time` is unsigned: seconds past 2**31 serialize as the codec does."""
    reg = default_registry()
    msg = reg.msg_class("rosgraph_msgs/Clock")(clock=_time(reg, 2**31 + 5, 7))
    assert ClockWriter("ros1").encode(2**31 + 5, 7) == reg.codec("rosgraph_msgs/Clock").encode(
        msg, "ros1"
    )


def test_wrong_value_count_is_an_error() -> None:
    writer = JointStateWriter("ros1", ["a", "b"])
    with pytest.raises(Exception, match="pack_into"):
        writer.encode(0, 0, [1.0], [1.0, 2.0], [1.0, 2.0])
