"""Golden comparison with Debian's genpy-generated ROS 1 Python modules (md5, text, bytes)."""

from __future__ import annotations

import importlib
import io
import pkgutil
import re
from pathlib import Path
from typing import Any

import pytest

from simbridge.messages import MessageRegistry

genpy = pytest.importorskip("genpy")

_DIST = Path("/usr/lib/python3/dist-packages")
_NON_ROS = {"genpy", "genmsg", "rospy", "roslib", "rosgraph"}


def _interface_modules(kind: str) -> list[Any]:
    modules = []
    for info in pkgutil.iter_modules([str(_DIST)]):
        if info.name in _NON_ROS or not (_DIST / info.name / kind / "__init__.py").exists():
            continue
        modules.append(importlib.import_module(f"{info.name}.{kind}"))
    return modules


def _classes(kind: str) -> list[Any]:
    found = []
    for module in _interface_modules(kind):
        for attr in sorted(dir(module)):
            cls = getattr(module, attr)
            if isinstance(cls, type) and isinstance(getattr(cls, "_md5sum", None), str):
                found.append(cls)
    return found


MESSAGE_CLASSES = [c for c in _classes("msg") if issubclass(c, genpy.Message)]
SERVICE_CLASSES = [c for c in _classes("srv") if not issubclass(c, genpy.Message)]
SERVICE_PART_CLASSES = [c for c in _classes("srv") if issubclass(c, genpy.Message)]


def _normalize(text: str) -> list[tuple[list[str], list[str]]]:
    """Per embedded message: its sorted constants and ordered fields, without comments,
    blank lines, spacing or package prefixes (`Header` vs `std_msgs/Header`): genmsg keeps
    the source text, while types from rosbags' store are regenerated. md5 covers the rest."""
    sections: list[tuple[list[str], list[str]]] = [([], [])]
    for raw in text.splitlines():
        if raw.startswith("MSG: "):
            sections.append(([raw], []))
            continue
        line = re.sub(r"\s*=\s*", "=", " ".join(raw.split("#", 1)[0].split()))
        line = line.rpartition("/")[2] if " " in line and "=" not in line else line
        if line and not line.startswith("====="):
            sections[-1][0 if "=" in line else 1].append(line)
    return [(sorted(consts), fields) for consts, fields in sections]


def test_debian_modules_were_found() -> None:
    packages = {cls._type.split("/")[0] for cls in MESSAGE_CLASSES}
    assert {"std_msgs", "geometry_msgs", "sensor_msgs", "tf2_msgs"} <= packages
    assert len(MESSAGE_CLASSES) > 90
    assert {cls._type for cls in SERVICE_CLASSES} >= {"std_srvs/SetBool", "std_srvs/Trigger"}


@pytest.mark.parametrize("cls", MESSAGE_CLASSES + SERVICE_PART_CLASSES, ids=lambda c: c._type)
def test_message_md5_and_definition_match_genpy(registry: MessageRegistry, cls: Any) -> None:
    assert registry.md5(cls._type) == cls._md5sum
    assert _normalize(registry.definition(cls._type)) == _normalize(cls._full_text)


@pytest.mark.parametrize("cls", SERVICE_CLASSES, ids=lambda c: c._type)
def test_service_md5_matches_genpy(registry: MessageRegistry, cls: Any) -> None:
    info = registry.service(cls._type)
    assert info.md5 == cls._md5sum
    assert info.request == cls._request_class._type
    assert info.response == cls._response_class._type
    assert registry.md5(cls._type) == cls._md5sum


def _genpy_bytes(msg: Any) -> bytes:
    buff = io.BytesIO()
    msg.serialize(buff)
    return buff.getvalue()


@pytest.mark.parametrize("cls", MESSAGE_CLASSES + SERVICE_PART_CLASSES, ids=lambda c: c._type)
def test_default_message_bytes_match_genpy(registry: MessageRegistry, cls: Any) -> None:
    expected = _genpy_bytes(cls())
    assert registry.encode(registry.new(cls._type)) == expected
    decoded = registry.decode(expected, cls._type)
    assert registry.encode(decoded, cls._type) == expected


def test_filled_messages_round_trip_with_genpy(registry: MessageRegistry) -> None:
    gm = importlib.import_module("geometry_msgs.msg")
    sm = importlib.import_module("sensor_msgs.msg")
    tm = importlib.import_module("tf2_msgs.msg")

    stamp = genpy.Time(1_700_000_000, 123_456_789)
    image = sm.Image(
        height=2, width=3, encoding="rgb8", is_bigendian=0, step=9, data=bytes(range(18))
    )
    image.header.stamp, image.header.frame_id, image.header.seq = stamp, "cam", 7
    imu = sm.Imu(orientation_covariance=[float(i) for i in range(9)])
    imu.angular_velocity.z = -2.5
    joints = sm.JointState(name=["a", "b"], position=[0.5, -1.0], velocity=[], effort=[3.0])
    transform = gm.TransformStamped(child_frame_id="tool")
    transform.transform.rotation.w = 1.0
    tf = tm.TFMessage(transforms=[transform, gm.TransformStamped(child_frame_id="base")])
    for msg in (image, imu, joints, tf):
        wire = _genpy_bytes(msg)
        ours = registry.decode(wire, msg._type)
        assert registry.encode(ours) == wire

    decoded = registry.decode(_genpy_bytes(image), "sensor_msgs/Image")
    assert decoded.header.stamp.sec == 1_700_000_000
    assert decoded.header.stamp.nanosec == 123_456_789
    assert bytes(decoded.data) == bytes(range(18))
    assert registry.to_dict(registry.decode(_genpy_bytes(joints), "sensor_msgs/JointState")) == {
        "header": {"seq": 0, "stamp": {"secs": 0, "nsecs": 0}, "frame_id": ""},
        "name": ["a", "b"],
        "position": [0.5, -1.0],
        "velocity": [],
        "effort": [3.0],
    }
