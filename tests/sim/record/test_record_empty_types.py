"""Recording a type with no fields that a client spelled as the CDR header alone (Unity's
ROS 2 serializer; the endpoint hands every client that spelling): the MCAP file holds
ROS 2's spelling, which rosbag2 readers decode, and a ROS 1 bag the empty ROS 1 message
(issue 36)."""

from __future__ import annotations

from pathlib import Path

import pytest
from rosbags.highlevel import AnyReader

from simbridge.messages import ros2_registry
from simbridge.sim.record import Recorder, RecordOptions

HEADER_ONLY = bytes.fromhex("00010000")
WITH_PLACEHOLDER = bytes.fromhex("0001000000")
ROS2_SPELLING = bytes.fromhex("0001000000000000")


def record(path: Path, payloads: list[bytes]) -> None:
    recorder = Recorder(RecordOptions(path), clock=lambda: 1.0)
    for payload in payloads:
        recorder.put("/ping", "std_msgs/Empty", payload, ros2_registry(), "cdr")
    stats = recorder.close()
    assert (stats.written, stats.failed, stats.dropped) == (len(payloads), 0, 0)


@pytest.mark.parametrize(("suffix", "stored"), [(".mcap", ROS2_SPELLING), (".bag", b"")])
def test_both_spellings_are_recorded_as_the_file_format_wants(
    tmp_path: Path, suffix: str, stored: bytes
) -> None:
    path = tmp_path / f"empty{suffix}"
    record(path, [HEADER_ONLY, WITH_PLACEHOLDER])
    with AnyReader([path]) as reader:
        rows = [(conn.msgtype, bytes(data)) for conn, _stamp, data in reader.messages()]
        decoded = [
            reader.deserialize(data, "std_msgs/msg/Empty") for _c, _s, data in reader.messages()
        ]
    assert rows == [("std_msgs/msg/Empty", stored)] * 2
    assert len(decoded) == 2


def test_a_payload_that_is_no_cdr_is_counted_not_recorded(tmp_path: Path) -> None:
    path = tmp_path / "bad.mcap"
    recorder = Recorder(RecordOptions(path), clock=lambda: 1.0)
    recorder.put("/ping", "std_msgs/Empty", b"\x00\x01", ros2_registry(), "cdr")
    recorder.put("/ping", "std_msgs/Empty", HEADER_ONLY, ros2_registry(), "cdr")
    stats = recorder.close()
    assert (stats.written, stats.failed) == (1, 1)
