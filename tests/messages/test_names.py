"""Type-name parsing."""

from __future__ import annotations

import pytest

from simbridge.messages import parse_type_name


@pytest.mark.parametrize(
    ("text", "canonical", "kind"),
    [
        ("geometry_msgs/Twist", "geometry_msgs/Twist", "msg"),
        ("geometry_msgs/msg/Twist", "geometry_msgs/Twist", "msg"),
        (" std_msgs/String ", "std_msgs/String", "msg"),
        ("std_srvs/srv/SetBool", "std_srvs/SetBool", "srv"),
        ("std_srvs/srv/SetBool_Request", "std_srvs/SetBoolRequest", "srv"),
        ("std_srvs/srv/SetBoolResponse", "std_srvs/SetBoolResponse", "srv"),
        ("tf2_msgs/action/LookupTransformGoal", "tf2_msgs/LookupTransformGoal", "action"),
    ],
)
def test_accepted_spellings(text: str, canonical: str, kind: str) -> None:
    parsed = parse_type_name(text)
    assert parsed is not None
    assert parsed.canonical == canonical
    assert parsed.kind == kind


@pytest.mark.parametrize(
    "text", ["", "Twist", "geometry_msgs/", "a/b/c/d", "pkg/foo/Type", "pkg/1Type", "p-kg/T"]
)
def test_rejected_spellings(text: str) -> None:
    assert parse_type_name(text) is None
