"""to_dict / JSON / MessagePack / YAML conversion."""

from __future__ import annotations

import base64
import json
import math

import msgpack
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from simbridge.errors import MessageError
from simbridge.messages import MessageRegistry


def _image(registry: MessageRegistry) -> object:
    return registry.new(
        "sensor_msgs/Image",
        header={"seq": 3, "stamp": {"secs": 10, "nsecs": 20}, "frame_id": "cam"},
        height=1,
        width=2,
        encoding="mono8",
        step=2,
        data=b"\x00\xff",
    )


def test_to_dict_plain_types(registry: MessageRegistry) -> None:
    assert registry.to_dict(_image(registry)) == {
        "header": {"seq": 3, "stamp": {"secs": 10, "nsecs": 20}, "frame_id": "cam"},
        "height": 1,
        "width": 2,
        "encoding": "mono8",
        "is_bigendian": 0,
        "step": 2,
        "data": b"\x00\xff",
    }
    imu = registry.to_dict(registry.new("sensor_msgs/Imu"))
    assert imu["orientation_covariance"] == [0.0] * 9
    assert isinstance(imu["orientation_covariance"][0], float)


def test_json_round_trip_uses_base64_for_bytes(registry: MessageRegistry) -> None:
    image = _image(registry)
    text = registry.to_json(image)
    assert json.loads(text)["data"] == base64.b64encode(b"\x00\xff").decode()
    assert registry.from_json("sensor_msgs/Image", text) == _decoded_equal(registry, image)
    with pytest.raises(MessageError, match="invalid JSON for sensor_msgs/Image"):
        registry.from_json("sensor_msgs/Image", "{")


def _decoded_equal(registry: MessageRegistry, msg: object) -> object:
    """Messages holding numpy arrays compare by value through their wire bytes."""
    return _WireEq(registry, msg)


class _WireEq:
    def __init__(self, registry: MessageRegistry, msg: object) -> None:
        self.registry, self.wire = registry, registry.encode(msg)

    def __eq__(self, other: object) -> bool:
        return self.registry.encode(other) == self.wire

    __hash__ = None  # type: ignore[assignment]


def test_msgpack_round_trip(registry: MessageRegistry) -> None:
    image = _image(registry)
    packed = registry.to_msgpack(image)
    assert msgpack.unpackb(packed)["data"] == b"\x00\xff"
    assert registry.from_msgpack("sensor_msgs/Image", packed) == _decoded_equal(registry, image)
    with pytest.raises(MessageError, match="invalid MessagePack"):
        registry.from_msgpack("sensor_msgs/Image", b"\xc1")


def test_yaml_like_rostopic_pub(registry: MessageRegistry) -> None:
    twist = registry.from_yaml("geometry_msgs/Twist", "{linear: {x: 0.5}, angular: {z: 1}}")
    assert (twist.linear.x, twist.angular.z) == (0.5, 1.0)
    positional = registry.from_yaml("geometry_msgs/Twist", "[[1, 2, 3], [4, 5, 6]]")
    assert positional.angular.y == 5.0
    assert registry.from_yaml("std_msgs/String", "hello").data == "hello"
    assert registry.from_yaml("std_msgs/Bool", "true").data is True
    assert registry.from_yaml("geometry_msgs/Twist", "") == registry.new("geometry_msgs/Twist")
    with pytest.raises(MessageError, match="invalid YAML"):
        registry.from_yaml("geometry_msgs/Twist", "{linear: [")
    with pytest.raises(MessageError, match="valid fields: x, y, z"):
        registry.from_yaml("geometry_msgs/Twist", "linear: {v: 1}")


finite = st.floats(allow_nan=False, allow_infinity=False)


@settings(max_examples=60, deadline=None)
@given(
    names=st.lists(st.text(max_size=8), max_size=4),
    positions=st.lists(finite, max_size=4),
    stamp=st.tuples(st.integers(0, 2**31 - 1), st.integers(0, 999_999_999)),
    seq=st.integers(0, 2**32 - 1),
)
def test_dict_json_msgpack_round_trips(
    registry: MessageRegistry,
    names: list[str],
    positions: list[float],
    stamp: tuple[int, int],
    seq: int,
) -> None:
    data = {
        "header": {"seq": seq, "stamp": {"secs": stamp[0], "nsecs": stamp[1]}, "frame_id": "f"},
        "name": names,
        "position": positions,
        "velocity": [],
        "effort": [],
    }
    msg = registry.from_dict("sensor_msgs/JointState", data)
    assert registry.to_dict(msg) == data
    assert (
        registry.to_dict(registry.from_json("sensor_msgs/JointState", registry.to_json(msg)))
        == data
    )
    unpacked = registry.from_msgpack("sensor_msgs/JointState", registry.to_msgpack(msg))
    assert registry.to_dict(unpacked) == data
    decoded = registry.decode(registry.encode(msg), "sensor_msgs/JointState")
    assert registry.to_dict(decoded) == data


def test_special_floats_survive_dicts(registry: MessageRegistry) -> None:
    msg = registry.new("sensor_msgs/JointState", position=[math.inf, -0.0])
    assert registry.to_dict(msg)["position"] == [math.inf, -0.0]
    assert np.signbit(registry.to_dict(msg)["position"][1])


def test_to_dict_rejects_non_messages(registry: MessageRegistry) -> None:
    with pytest.raises(MessageError, match="not a message object: dict"):
        registry.to_dict({"x": 1})


json_like = st.recursive(
    st.none()
    | st.booleans()
    | st.integers(-(2**70), 2**70)
    | st.floats()
    | st.text(max_size=6)
    | st.binary(max_size=6),
    lambda children: (
        st.lists(children, max_size=4)
        | st.dictionaries(
            st.sampled_from(["x", "data", "header", "stamp", "secs", "linear", "name", "position"]),
            children,
            max_size=4,
        )
    ),
    max_leaves=12,
)


@settings(max_examples=200, deadline=None)
@given(
    name=st.sampled_from(
        ["geometry_msgs/Twist", "sensor_msgs/JointState", "std_msgs/Header", "sensor_msgs/Image"]
    ),
    data=json_like,
)
def test_arbitrary_data_gives_message_or_message_error(
    registry: MessageRegistry, name: str, data: object
) -> None:
    try:
        msg = registry.from_dict(name, data)
    except MessageError:
        return
    assert registry.decode(registry.encode(msg), name) is not None


def _strict_loads(text: str) -> object:
    def refuse(token: str) -> object:
        raise AssertionError(f"not JSON: bare {token}")

    return json.loads(text, parse_constant=refuse)


def test_json_is_strict_non_finite_floats_become_null(registry: MessageRegistry) -> None:
    """JSON has no NaN/Infinity: they are written as null (rosbridge's choice), read as NaN."""
    scan = registry.from_dict(
        "sensor_msgs/LaserScan",
        {
            "angle_min": math.nan,
            "range_max": math.inf,
            "ranges": [1.5, math.inf, -math.inf, math.nan],
        },
    )
    text = registry.to_json(scan)
    for token in ("NaN", "Infinity"):
        assert token not in text
    data = _strict_loads(text)
    assert isinstance(data, dict)
    assert (data["angle_min"], data["range_max"]) == (None, None)
    assert data["ranges"] == [1.5, None, None, None]
    back = registry.from_json("sensor_msgs/LaserScan", text)
    assert math.isnan(back.angle_min)
    assert math.isnan(back.range_max)
    assert back.ranges[0] == 1.5
    assert np.isnan(back.ranges[1:]).all()
    assert back.ranges.dtype == np.float32


def test_json_of_finite_messages_is_unchanged(registry: MessageRegistry) -> None:
    twist = registry.new("geometry_msgs/Twist", linear={"x": 0.5})
    assert registry.to_json(twist) == (
        '{"linear":{"x":0.5,"y":0.0,"z":0.0},"angular":{"x":0.0,"y":0.0,"z":0.0}}'
    )
