"""An rclpy node on simulated time, run with the ROS 2 venv's Python by the tests (never
imported by pytest). Start it with `--ros-args -p use_sim_time:=true`.

It prints {"ready": true} once subscribed to /clock, then for every tick of a 0.5 s timer
on the node's clock {"tick": nanoseconds of node time}, and stops after COUNT ticks.

    clock_follower.py COUNT --ros-args -p use_sim_time:=true
"""

from __future__ import annotations

import contextlib
import json
import sys

import rclpy


def main(argv: list[str]) -> None:
    rclpy.init(args=argv)
    count = int(rclpy.utilities.remove_ros_args(argv)[1])
    node = rclpy.create_node("simbridge_clock_follower")
    ticks: list[int] = []
    try:
        use_sim_time = node.get_parameter("use_sim_time").value
        node.create_timer(0.5, lambda: ticks.append(node.get_clock().now().nanoseconds))
        print(json.dumps({"ready": True, "use_sim_time": use_sim_time}), flush=True)
        while rclpy.ok() and count > 0:
            rclpy.spin_once(node, timeout_sec=0.1)
            while ticks and count > 0:
                print(json.dumps({"tick": ticks.pop(0)}), flush=True)
                count -= 1
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    with contextlib.suppress(KeyboardInterrupt):
        main(sys.argv)
