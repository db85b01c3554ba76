"""backends.ros2.rcl: a bytearray published in place through rcl reaches a raw subscription intact.

Runs in a ROS 2 venv child (rclpy), publisher and subscription in one node.
"""

from __future__ import annotations

import textwrap

import pytest
from tests.ros2support import Ros2Process

pytestmark = [pytest.mark.ros2, pytest.mark.timeout(120)]

_SCRIPT = textwrap.dedent(
    """
    import json, struct, time
    import rclpy
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from rclpy.serialization import deserialize_message
    from sensor_msgs.msg import Image
    from simbridge.endpoint.backends.ros2.rcl import direct_publish

    def cdr_string(text):
        raw = text.encode() + b"\\0"
        return struct.pack("<I", len(raw)) + raw

    # sensor_msgs/Image 640x480 rgb8: header (stamp 7.8, "cam"), then the image fields
    pixels = bytes(i % 251 for i in range(640 * 480 * 3))
    head = b"\\x00\\x01\\x00\\x00" + struct.pack("<iI", 7, 8) + cdr_string("cam")
    head += b"\\0" * (-(len(head) - 4) % 4) + struct.pack("<II", 480, 640) + cdr_string("rgb8")
    head += b"\\0"
    head += b"\\0" * (-(len(head) - 4) % 4) + struct.pack("<II", 640 * 3, len(pixels))
    payload = bytearray(head + pixels)

    rclpy.init()
    node = rclpy.create_node("sb_rcl_probe")
    qos = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
    got = []
    node.create_subscription(Image, "/sb_rcl_image", got.append, qos, raw=True)
    pub = node.create_publisher(Image, "/sb_rcl_image", qos)
    publish = direct_publish(pub)
    deadline = time.monotonic() + 20
    while pub.get_subscription_count() == 0 and time.monotonic() < deadline:
        rclpy.spin_once(node, timeout_sec=0.05)
    publish(payload)
    while not got and time.monotonic() < deadline:
        rclpy.spin_once(node, timeout_sec=0.05)
    msg = deserialize_message(got[0], Image) if got else None
    print(json.dumps({"result": {
        "direct": publish is not None,
        "size": len(got[0]) if got else 0,
        "sent": len(payload),
        "stamp": [msg.header.stamp.sec, msg.header.stamp.nanosec] if msg else None,
        "frame": msg.header.frame_id if msg else None,
        "shape": [msg.width, msg.height, msg.encoding] if msg else None,
        "pixels_equal": bytes(msg.data) == pixels if msg else False,
    }}), flush=True)
    node.destroy_node()
    rclpy.shutdown()
    """
)


def test_a_bytearray_published_in_place_arrives_intact() -> None:
    """direct_publish reaches rcl (no fallback) and the subscriber decodes the very image."""
    with Ros2Process(["-c", _SCRIPT]) as proc:
        result = proc.expect_json("result", timeout=60)
    assert result["direct"], "rcl_publish_serialized_message was not reachable"
    assert result["sent"] <= result["size"] <= result["sent"] + 4, result
    assert result["stamp"] == [7, 8]
    assert result["frame"] == "cam"
    assert result["shape"] == [640, 480, "rgb8"]
    assert result["pixels_equal"]


_TAKE_SCRIPT = textwrap.dedent(
    """
    import json, time
    import rclpy
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from rclpy.serialization import deserialize_message
    from sensor_msgs.msg import Image
    from simbridge.endpoint.backends.ros2.rcl import direct_take

    rclpy.init()
    node = rclpy.create_node("sb_rcl_take")
    qos = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
    sub = node.create_subscription(Image, "/sb_rcl_take", lambda _m: None, qos, raw=True)
    pub = node.create_publisher(Image, "/sb_rcl_take", qos)
    take = direct_take(sub)
    deadline = time.monotonic() + 20
    while pub.get_subscription_count() == 0 and time.monotonic() < deadline:
        time.sleep(0.05)
    with sub.handle:
        empty = take.take() is None
    widths = [10, 921_600, 300_000, 2_000_000]  # the buffer grows, then is reused
    got = []
    for seed, width in enumerate(widths):
        pub.publish(Image(height=1, width=width, encoding="mono8", step=width,
                          data=bytes((seed + i) % 251 for i in range(251)) * (width // 251)))
        view = None
        while view is None and time.monotonic() < deadline:
            with sub.handle:
                view = take.take()
            time.sleep(0.01) if view is None else None
        msg = deserialize_message(bytes(view), Image) if view is not None else None
        got.append(None if msg is None else {
            "width": msg.width,
            "pixels_equal": bytes(msg.data) == bytes(
                (seed + i) % 251 for i in range(251)) * (width // 251),
        })
    take.close()
    take.close()  # a second close is harmless
    print(json.dumps({"result": {"direct": True, "empty": empty, "got": got,
                                 "widths": widths}}), flush=True)
    node.destroy_node()
    rclpy.shutdown()
    """
)


def test_direct_take_hands_over_each_message_through_its_own_buffer() -> None:
    """direct_take reaches rcl: None while nothing waits, then each message whole as its
    buffer grows for a larger one and is reused for a smaller one; close() twice is fine."""
    with Ros2Process(["-c", _TAKE_SCRIPT]) as proc:
        result = proc.expect_json("result", timeout=60)
    assert result["empty"]
    assert [m and m["width"] for m in result["got"]] == result["widths"]
    assert all(m["pixels_equal"] for m in result["got"])
