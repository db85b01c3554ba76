"""`__set_param` (simbridge extension): golden frame and validation."""

from __future__ import annotations

import pytest

from simbridge.errors import ProtocolError
from simbridge.protocol import EXTENSIONS, SetParam, decode_command


def test_golden_set_param_frame() -> None:
    frame = SetParam("/robot_description", "<robot/>").encode()
    body = b'{"name": "/robot_description", "value": "<robot/>"}'
    assert frame == b"\x0b\x00\x00\x00__set_param" + len(body).to_bytes(4, "little") + body
    assert decode_command("__set_param", body, sender="client") == SetParam(
        "/robot_description", "<robot/>"
    )
    assert "set_param" in EXTENSIONS


def test_any_json_value_but_null() -> None:
    body = b'{"name": "/arm/limits", "value": {"max": [1, 2.5], "on": true}}'
    decoded = decode_command("__set_param", body, sender="client")
    assert decoded == SetParam("/arm/limits", {"max": [1, 2.5], "on": True})


@pytest.mark.parametrize(
    ("body", "needle"),
    [
        (b'{"name": "/a"}', "has no 'value'"),
        (b'{"name": "/a", "value": null}', "cannot be null"),
        (b'{"name": "a b", "value": 1}', "contains whitespace"),
        (b'{"name": "", "value": 1}', "blank"),
        (b'{"value": 1}', "'name' must be a string"),
    ],
)
def test_bad_set_param_names_the_problem(body: bytes, needle: str) -> None:
    with pytest.raises(ProtocolError, match=needle):
        decode_command("__set_param", body, sender="client")


def test_only_clients_send_it() -> None:
    with pytest.raises(
        ProtocolError, match="unknown system command '__set_param' from the endpoint"
    ):
        decode_command("__set_param", b'{"name": "/a", "value": 1}', sender="endpoint")
