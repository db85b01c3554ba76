"""A ROS 2 node that counts the Twists on a topic and checks their order, run with the ROS 2
venv's Python (never imported by pytest). One JSON object per line on stdout.

    twist_counter.py TOPIC EXPECTED QUIET [GO]
        a reliable keep-all subscription to geometry_msgs/msg/Twist on TOPIC; prints
        {"ready": true} once made; with GO (a path) takes nothing before that file exists
        (DDS then holds what it cannot hand over: the publisher must keep it); then, once
        EXPECTED messages arrived or none came for QUIET seconds after the first, prints
        {"count": n, "in_order": bool, "first": t, "last": t}: in_order when message k
        carried linear.x == k for every k, first and last the time.monotonic() (the
        system's monotonic clock) of the first and last arrival
"""

from __future__ import annotations

import json
import os
import struct
import sys
import time

import rclpy
from geometry_msgs.msg import Twist  # type: ignore[import-untyped]
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

_X = struct.Struct("<d")
"""linear.x in a Twist's little-endian CDR: right after the 4-byte encapsulation header."""


def main(argv: list[str]) -> None:
    topic, expected, quiet = argv[0], int(argv[1]), float(argv[2])
    go = argv[3] if len(argv) > 3 else None
    rclpy.init()
    node = rclpy.create_node("simbridge_twist_counter")
    state = {"count": 0, "in_order": True, "first": 0.0, "last": 0.0}
    qos = QoSProfile(history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.RELIABLE)
    subscription = node.create_subscription(Twist, topic, lambda _: None, qos, raw=True)
    print(json.dumps({"ready": True}), flush=True)
    while go is not None and not os.path.exists(go) and rclpy.ok():
        time.sleep(0.01)
    try:
        # Taken straight from the subscription, not through an executor's callbacks
        # (spin_once costs more than the message): the counter keeps up with the endpoint.
        with subscription.handle:
            take = subscription.handle.take_message
            while rclpy.ok() and state["count"] < expected:
                taken = take(Twist, True)
                if taken is None:
                    if state["count"] and time.monotonic() - float(state["last"]) > quiet:
                        break
                    time.sleep(0.001)
                    continue
                now = time.monotonic()
                if state["count"] == 0:
                    state["first"] = now
                state["last"] = now
                if _X.unpack_from(taken[0], 4)[0] != state["count"]:
                    state["in_order"] = False
                state["count"] += 1
        print(json.dumps(state), flush=True)
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    main(sys.argv[1:])
