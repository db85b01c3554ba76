"""The publisher of bench_ros2.py's "sim -> ros2 (in-process node)" rows: the sim as its own
ROS 2 node (`simbridge.apps.ros2_node`, what `simbridge sim SCENE --ros2` runs).

A process of the ROS 2 venv makes a `Ros2SimNode` and publishes the payload through its
connector's publisher (`DirectPublisher`: straight into rclpy on the calling thread, as a
sim's camera or state publisher does), taking the same command-line arguments and stdin
cues as the ceiling's rclpy publisher, so the row is measured by the same subscriber
process against the ceiling of the same round. Run by bench_ros2.py, not on its own.
"""

from __future__ import annotations

import contextlib
import json
import sys
import time

from simbridge.apps.ros2_node import Ros2SimNode

__all__ = ["main"]


def main(argv: list[str]) -> None:
    """`bench_ros2_sim_node.py pub TOPIC TYPE COUNT PAYLOAD_FILE`: READY once the subscriber is
    matched, then on a line of stdin publish COUNT times and print {"sent", "start"}."""
    topic, msg_type, count = argv[2], argv[3], int(argv[4])
    with open(argv[5], "rb") as f:
        payload = f.read()
    with Ros2SimNode("bench_sim_node") as node:
        connector = node.connector()
        publisher = connector.register_publisher(
            topic, msg_type, queue_size=max(count, 10), report_subscribers=True
        )
        deadline = time.monotonic() + 60
        while (publisher.subscriber_count or 0) < 1 and time.monotonic() < deadline:
            time.sleep(0.01)
        time.sleep(0.3)
        print("READY", flush=True)
        sys.stdin.readline()
        publish = publisher.publish
        start = time.perf_counter()
        for _ in range(count):
            publish(payload)
        print(json.dumps({"sent": count, "start": start}), flush=True)
        sys.stdin.readline()
        connector.close()


if __name__ == "__main__":
    with contextlib.suppress(KeyboardInterrupt):  # stopped with SIGINT by the bench
        main(sys.argv)
