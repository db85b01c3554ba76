"""A failed encode names the offending field, its value and the accepted range, for any
integer field of any depth (including inside lists), in both wire formats."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from simbridge.errors import MessageError
from simbridge.messages import MessageRegistry, default_registry
from simbridge.messages.schema import NUMPY_DTYPES

TYPES = ["sensor_msgs/CameraInfo", "sensor_msgs/PointCloud2", "nav_msgs/OccupancyGrid"]
_RANGES = {
    name: (int(np.iinfo(dtype).min), int(np.iinfo(dtype).max))
    for name, dtype in NUMPY_DTYPES.items()
    if dtype.kind in "iu"
}


def _int_fields(registry: MessageRegistry, name: str, prefix: str) -> list[tuple[str, str]]:
    """(path, type) of every scalar integer field reachable without entering a list."""
    found = []
    for spec in registry.schema(name).fields:
        path = f"{prefix}.{spec.name}"
        if spec.array:
            continue
        if spec.is_message:
            found += _int_fields(registry, spec.type, path)
        elif spec.type in _RANGES:
            found.append((path, spec.type))
    return found


CASES: list[tuple[str, str, str]] = [
    (name, path, typ) for name in TYPES for path, typ in _int_fields(default_registry(), name, name)
]


def _set(msg: Any, dotted: str, value: int) -> None:
    parts = dotted.split(".")[1:]
    target = msg
    for part in parts[:-1]:
        target = getattr(target, part)
    setattr(target, parts[-1], value)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    case=st.sampled_from(CASES),
    above=st.booleans(),
    offset=st.integers(1, 2**70),
    fmt=st.sampled_from(["ros1", "cdr"]),
)
def test_out_of_range_integer_is_named(
    case: tuple[str, str, str], above: bool, offset: int, fmt: str
) -> None:
    registry = default_registry()
    name, path, typ = case
    low, high = _RANGES[typ]
    value = high + offset if above else low - offset
    msg = registry.new(name)
    _set(msg, path, value)
    with pytest.raises(MessageError) as info:
        registry.encode(msg, fmt=fmt)  # type: ignore[arg-type]
    assert f"{path}: {value} is out of range for {typ} [{low}, {high}]" in str(info.value)


def test_field_inside_a_list_is_named_with_its_index(registry: MessageRegistry) -> None:
    cloud = registry.from_dict(
        "sensor_msgs/PointCloud2", {"fields": [{"name": "x"}, {"name": "y", "datatype": 7}]}
    )
    cloud.fields[1].offset = -4
    with pytest.raises(MessageError, match=r"PointCloud2\.fields\[1\]\.offset: -4 is out of range"):
        registry.encode(cloud)
    cloud.fields[1].offset = 4
    cloud.fields[0].name = 7
    with pytest.raises(MessageError, match=r"PointCloud2\.fields\[0\]\.name: expected a string"):
        registry.encode(cloud)


def test_wrong_nested_message_is_named(registry: MessageRegistry) -> None:
    twist = registry.new("geometry_msgs/Twist")
    twist.linear = registry.new("std_msgs/String", data="fast")
    with pytest.raises(
        MessageError,
        match=r"Twist\.linear: expected a geometry_msgs/Vector3 message, got std_msgs/String",
    ):
        registry.encode(twist)
    twist.linear = 0.5
    with pytest.raises(
        MessageError, match=r"Twist\.linear: expected a geometry_msgs/Vector3 message, got 0\.5"
    ):
        registry.encode(twist)
