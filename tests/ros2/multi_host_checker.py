"""The checker of test_multi_host.py, an rclpy node on a host of its own (ROS 2 venv).

    multi_host_checker.py NAMESPACE [NAMESPACE ...] TIMEOUT

Waits until the graph lists `<NAMESPACE>/joint_states` for every namespace and one
sensor_msgs/JointState arrived on each, then prints {"seen": {topic: {"publishers": n,
"joints": [...], "types": [...]}}}; after TIMEOUT s it prints what it had and exits 1.
"""

from __future__ import annotations

import json
import sys
import time
from typing import Any

import rclpy
from sensor_msgs.msg import JointState  # type: ignore[import-untyped]


def main() -> int:
    *namespaces, timeout = sys.argv[1:]
    topics = [f"{ns.rstrip('/')}/joint_states" for ns in namespaces]
    rclpy.init()
    node = rclpy.create_node("multi_host_checker")
    first: dict[str, list[str]] = {}

    def keep(topic: str) -> Any:
        return lambda msg: first.setdefault(topic, list(msg.name))

    subs = [node.create_subscription(JointState, t, keep(t), 10) for t in topics]
    deadline = time.monotonic() + float(timeout)
    seen: dict[str, dict[str, object]] = {}
    while time.monotonic() < deadline:
        rclpy.spin_once(node, timeout_sec=0.2)
        graph = dict(node.get_topic_names_and_types())
        seen = {
            t: {
                "types": graph.get(t, []),
                "publishers": node.count_publishers(t),
                "joints": first.get(t),
            }
            for t in topics
        }
        if all(t in graph and t in first for t in topics):
            break
    print(json.dumps({"seen": seen}), flush=True)
    ok = all(t in first for t in topics)
    del subs
    node.destroy_node()
    rclpy.try_shutdown()
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
