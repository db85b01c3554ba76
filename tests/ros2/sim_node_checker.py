"""An rclpy node that checks a sim run as its own ROS 2 node (`simbridge sim mobile-robot
--ros2`), run with the ROS 2 venv's Python by tests/ros2/test_sim_node.py (never imported
by pytest). Every step waits on messages or answers, bounded by WAIT seconds, and prints
one JSON line; a step that times out prints {"error": ...} and the checker stops.

    sim_node_checker.py NODE_NAME
"""

from __future__ import annotations

import contextlib
import importlib
import json
import sys
import time
from collections.abc import Callable
from typing import Any

import rclpy
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy


def _interface(module: str, name: str) -> Any:
    """An installed ROS 2 interface class (untyped: imported by name)."""
    return getattr(importlib.import_module(module), name)


Twist = _interface("geometry_msgs.msg", "Twist")
Odometry = _interface("nav_msgs.msg", "Odometry")
Parameter = _interface("rcl_interfaces.msg", "Parameter")
ParameterType = _interface("rcl_interfaces.msg", "ParameterType")
ParameterValue = _interface("rcl_interfaces.msg", "ParameterValue")
GetParameters = _interface("rcl_interfaces.srv", "GetParameters")
SetParameters = _interface("rcl_interfaces.srv", "SetParameters")
Clock = _interface("rosgraph_msgs.msg", "Clock")
Image = _interface("sensor_msgs.msg", "Image")
JointState = _interface("sensor_msgs.msg", "JointState")
String = _interface("std_msgs.msg", "String")
Empty = _interface("std_srvs.srv", "Empty")
SetBool = _interface("std_srvs.srv", "SetBool")
TFMessage = _interface("tf2_msgs.msg", "TFMessage")

WAIT = 60.0


class StepTimeoutError(Exception):
    """A step got nothing within WAIT seconds."""


def emit(**obj: object) -> None:
    print(json.dumps(obj), flush=True)


class Checker:
    def __init__(self, node: Any) -> None:
        self.node = node
        self.latest: dict[str, Any] = {}
        self.tf_pairs: set[str] = set()
        """Every parent->child seen on /tf."""
        latched = QoSProfile(
            depth=1,
            reliability=ReliabilityPolicy.RELIABLE,
            durability=DurabilityPolicy.TRANSIENT_LOCAL,
        )
        for topic, cls, qos in (
            ("/joint_states", JointState, 10),
            ("/clock", Clock, 10),
            ("/tf", TFMessage, 10),
            ("/tf_static", TFMessage, latched),
            ("/camera/image_raw", Image, 10),
            ("/odom", Odometry, 10),
            ("/robot_description", String, latched),
        ):
            node.create_subscription(cls, topic, self._keep(topic), qos)

    def _keep(self, topic: str) -> Callable[[Any], None]:
        def keep(msg: Any) -> None:
            self.latest[topic] = msg
            if topic == "/tf":
                self.tf_pairs.update(
                    f"{t.header.frame_id}->{t.child_frame_id}" for t in msg.transforms
                )

        return keep

    def until(self, what: str, test: Callable[[], Any]) -> Any:
        """Spin until `test()` is truthy; its value (StepTimeoutError after WAIT s)."""
        deadline = time.monotonic() + WAIT
        while time.monotonic() < deadline:
            value = test()
            if value:
                return value
            rclpy.spin_once(self.node, timeout_sec=0.05)
        raise StepTimeoutError(f"no {what} within {WAIT} s")

    def message(self, topic: str, test: Callable[[Any], bool] = lambda _m: True) -> Any:
        """The next message on `topic` (after this call) that passes `test`."""
        self.latest.pop(topic, None)
        return self.until(
            topic, lambda: (m := self.latest.get(topic)) is not None and test(m) and m
        )

    def call(self, service: str, cls: Any, request: Any) -> Any:
        client = self.node.create_client(cls, service)
        try:
            self.until(f"server of {service}", client.service_is_ready)
            future = client.call_async(request)
            return self.until(f"answer of {service}", lambda: future.done() and future.result())
        finally:
            self.node.destroy_client(client)


def clock_s(msg: Any) -> float:
    return float(msg.clock.sec + msg.clock.nanosec * 1e-9)


def run(check: Checker, sim_node: str) -> None:
    node = check.node
    check.until(f"node {sim_node}", lambda: sim_node in node.get_node_names())
    emit(node=sim_node)
    joints = check.message("/joint_states")
    emit(joint_states=list(joints.name))
    clock = check.message("/clock", lambda m: clock_s(m) > 0.2)
    emit(clock=clock_s(clock))
    wanted = {"odom->base_link", "base_link->left_wheel_link"}  # odometry's, the robot's
    check.until(f"/tf with {wanted}", lambda: wanted <= check.tf_pairs)
    emit(tf=sorted(check.tf_pairs))
    static = check.until("/tf_static", lambda: check.latest.get("/tf_static"))
    emit(tf_static=sorted(t.child_frame_id for t in static.transforms))
    image = check.message("/camera/image_raw")
    emit(
        image={
            "width": image.width,
            "height": image.height,
            "encoding": image.encoding,
            "bytes": len(image.data),
            "step": image.step,
            "frame_id": image.header.frame_id,
        }
    )
    description = check.until("/robot_description", lambda: check.latest.get("/robot_description"))
    emit(robot_description="<robot" in description.data)

    # /cmd_vel drives the base: odometry reports it moving forward
    start = check.message("/odom")
    x0 = start.pose.pose.position.x
    emit(odom={"frame_id": start.header.frame_id, "child": start.child_frame_id})
    cmd = node.create_publisher(Twist, "/cmd_vel", 10)
    twist = Twist()
    twist.linear.x = 0.5
    timer = node.create_timer(0.05, lambda: cmd.publish(twist))
    moved = check.message("/odom", lambda m: m.pose.pose.position.x > x0 + 0.05)
    node.destroy_timer(timer)
    cmd.publish(Twist())
    emit(moved=moved.pose.pose.position.x - x0)

    # the sim's services: pause answers with the sim time, reset sends the clock back
    paused = check.call("/simbridge/pause", SetBool, SetBool.Request(data=True))
    emit(pause={"success": paused.success, "message": paused.message})
    resumed = check.call("/simbridge/pause", SetBool, SetBool.Request(data=False))
    emit(resume={"success": resumed.success, "message": resumed.message})
    before = clock_s(check.message("/clock", lambda m: clock_s(m) > 0.5))
    check.call("/simbridge/reset", Empty, Empty.Request())
    after = clock_s(check.message("/clock", lambda m: clock_s(m) < before))
    emit(reset={"before": before, "after": after})

    # the node's own parameters (its executor answers rclpy's parameter services)
    value = ParameterValue(type=ParameterType.PARAMETER_BOOL, bool_value=True)
    request = SetParameters.Request(parameters=[Parameter(name="use_sim_time", value=value)])
    result = check.call(f"/{sim_node}/set_parameters", SetParameters, request)
    got = check.call(
        f"/{sim_node}/get_parameters", GetParameters, GetParameters.Request(names=["use_sim_time"])
    )
    emit(param={"set": result.results[0].successful, "value": got.values[0].bool_value})


def main(argv: list[str]) -> None:
    rclpy.init()
    node = rclpy.create_node("simbridge_test_sim_node_checker")
    try:
        run(Checker(node), argv[1])
    except StepTimeoutError as exc:
        emit(error=str(exc))
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    emit(done=True)


if __name__ == "__main__":
    with contextlib.suppress(KeyboardInterrupt):
        main(sys.argv)
