"""A ROS 2 helper node for the tests, run with the ROS 2 venv's Python (never imported by
pytest, which runs beside rospy). One JSON object per line on stdout.

    ros2_node.py echo TOPIC pkg/msg/Type COUNT [--latched] [--raw]
        print {"ready": true}, then each message as {"msg": {...}} (decoded with rclpy);
        with --raw, as {"raw": "hex"}: its CDR bytes as DDS delivered them
    ros2_node.py pub TOPIC pkg/msg/Type JSON RATE COUNT
        once a subscription matched (30 s at most), publish JSON (field values) COUNT times
        at RATE Hz; {"sent": n} at the end
    ros2_node.py burst TOPIC COUNT
        once a subscription matched, publish std_msgs/msg/UInt32 0..COUNT-1 as fast as
        it can (reliable, a history as deep as COUNT); {"sent": n} once all are acknowledged
    ros2_node.py images TOPIC COUNT WIDTH,WIDTH,...
        once a subscription matched, publish COUNT sensor_msgs/msg/Image (mono8, one row)
        as fast as it can (reliable, a history as deep as COUNT): image i has stamp.sec i,
        the widths in turn and pixels (i + k) % 251; {"sent": n} once all are acknowledged
    ros2_node.py serve SERVICE pkg/srv/Type JSON
        answer every request with JSON; print {"request": {...}} per call
    ros2_node.py call SERVICE pkg/srv/Type JSON TIMEOUT
        wait for the server, call once, print {"response": {...}} or {"error": "..."}
    ros2_node.py graph SECONDS
        print {"topics": [[name, [types]], ...]} of the graph after SECONDS
    ros2_node.py clients NODE SECONDS
        print {"clients": [name, ...]}: the services node /NODE has clients of, after SECONDS
        (and once /NODE is known, 30 s at most)
    ros2_node.py lookup ACTION
        a tf2_msgs/action/LookupTransform action server (its Feedback has no fields): each
        goal gets two feedback messages, then a result from target_frame to source_frame.
        Prints {"ready": true}, then {"goal": target_frame} per goal
    ros2_node.py fibonacci ACTION PERIOD [--reject]
        a test_msgs/action/Fibonacci action server: each goal gets one feedback per term
        every PERIOD s, then the sequence as result; it honours cancel requests, and with
        --reject refuses every goal. Prints {"ready": true}, then {"goal": order},
        {"canceled": order}, {"rejected": order} and {"finished": order}
"""

from __future__ import annotations

import contextlib
import importlib
import json
import sys
import time
from typing import Any

import rclpy
import rclpy.duration
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy


def load(name: str) -> Any:
    package, kind, base = name.split("/")
    return getattr(importlib.import_module(f"{package}.{kind}"), base)


def message_to_ordereddict(msg: Any) -> Any:
    """Field values as plain JSON data (nested messages as dicts)."""
    if hasattr(msg, "get_fields_and_field_types"):
        fields = msg.get_fields_and_field_types()
        return {k: message_to_ordereddict(getattr(msg, k)) for k in fields}
    if isinstance(msg, bytes | bytearray):
        return list(msg)
    if hasattr(msg, "tolist"):
        msg = msg.tolist()
    if isinstance(msg, list | tuple):
        return [message_to_ordereddict(v) for v in msg]
    return msg


def set_message_fields(msg: Any, values: dict[str, Any]) -> None:
    """Set fields from a dict (nested messages from nested dicts)."""
    for key, value in values.items():
        current = getattr(msg, key)
        if isinstance(value, dict):
            set_message_fields(current, value)
        else:
            setattr(msg, key, value)


def emit(obj: object) -> None:
    print(json.dumps(obj, default=repr), flush=True)


def main(argv: list[str]) -> None:
    rclpy.init()
    node = rclpy.create_node(f"simbridge_test_{argv[0]}")
    try:
        run(node, argv)
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


def matched_publisher(node: Any, cls: Any, topic: str, qos: Any) -> Any:
    """A publisher, once a subscription matched it or 60 s passed (discovery can be slow on
    a busy machine)."""
    publisher = node.create_publisher(cls, topic, qos)
    deadline = time.monotonic() + 60
    while publisher.get_subscription_count() == 0 and time.monotonic() < deadline:
        rclpy.spin_once(node, timeout_sec=0.05)
    return publisher


def run(node: Any, argv: list[str]) -> None:
    mode = argv[0]
    if mode == "echo":
        topic, cls, count = argv[1], load(argv[2]), int(argv[3])
        latched = "--latched" in argv
        qos = QoSProfile(
            depth=100,
            reliability=ReliabilityPolicy.RELIABLE,
            durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE,
        )
        raw = "--raw" in argv
        got: list[Any] = []
        node.create_subscription(cls, topic, got.append, qos, raw=raw)
        emit({"ready": True})
        while rclpy.ok() and len(got) < count:
            rclpy.spin_once(node, timeout_sec=0.1)
            while got:
                message = got.pop(0)
                emit({"raw": message.hex()} if raw else {"msg": message_to_ordereddict(message)})
                count -= 1
    elif mode == "pub":
        topic, cls, values = argv[1], load(argv[2]), json.loads(argv[3])
        rate, count = float(argv[4]), int(argv[5])
        msg = cls()
        set_message_fields(msg, values)
        publisher = matched_publisher(node, cls, topic, 10)
        for _ in range(count):
            publisher.publish(msg)
            rclpy.spin_once(node, timeout_sec=1.0 / rate)
        # reliable: what is not acknowledged yet would be lost if the node left now
        publisher.wait_for_all_acked(rclpy.duration.Duration(seconds=30))
        emit({"sent": count})
    elif mode == "burst":
        topic, count = argv[1], int(argv[2])
        cls = load("std_msgs/msg/UInt32")
        qos = QoSProfile(depth=count, reliability=ReliabilityPolicy.RELIABLE)
        publisher = matched_publisher(node, cls, topic, qos)
        for i in range(count):
            publisher.publish(cls(data=i))
        publisher.wait_for_all_acked(rclpy.duration.Duration(seconds=30))
        emit({"sent": count})
    elif mode == "images":
        topic, count = argv[1], int(argv[2])
        widths = [int(w) for w in argv[3].split(",")]
        cls = load("sensor_msgs/msg/Image")
        qos = QoSProfile(depth=count, reliability=ReliabilityPolicy.RELIABLE)
        publisher = matched_publisher(node, cls, topic, qos)
        for i in range(count):
            width = widths[i % len(widths)]
            msg = cls(height=1, width=width, encoding="mono8", step=width)
            msg.header.stamp.sec = i
            row = bytes((i + k) % 251 for k in range(251))
            msg.data = row * (width // 251) + row[: width % 251]
            publisher.publish(msg)
        publisher.wait_for_all_acked(rclpy.duration.Duration(seconds=60))
        emit({"sent": count})
    elif mode == "serve":
        service, cls, values = argv[1], load(argv[2]), json.loads(argv[3])

        def answer(request: Any, response: Any) -> Any:
            emit({"request": message_to_ordereddict(request)})
            set_message_fields(response, values)
            return response

        node.create_service(cls, service, answer)
        emit({"ready": True})
        rclpy.spin(node)
    elif mode == "call":
        service, cls, values, timeout = argv[1], load(argv[2]), json.loads(argv[3]), float(argv[4])
        client = node.create_client(cls, service)
        if not client.wait_for_service(timeout_sec=timeout):
            emit({"error": f"no server for {service}"})
            return
        request = cls.Request()
        set_message_fields(request, values)
        future = client.call_async(request)
        rclpy.spin_until_future_complete(node, future, timeout_sec=timeout)
        if future.done():
            emit({"response": message_to_ordereddict(future.result())})
        else:
            emit({"error": f"no answer from {service} within {timeout} s"})
    elif mode == "graph":
        deadline = time.monotonic() + float(argv[1])
        while time.monotonic() < deadline:
            rclpy.spin_once(node, timeout_sec=0.05)
        emit({"topics": node.get_topic_names_and_types()})
    elif mode == "clients":
        start = time.monotonic()
        while time.monotonic() < start + float(argv[2]) or (
            argv[1] not in node.get_node_names() and time.monotonic() < start + 30
        ):
            rclpy.spin_once(node, timeout_sec=0.05)
        found = node.get_client_names_and_types_by_node(argv[1], "/")
        emit({"clients": sorted(name for name, _types in found)})
    elif mode == "lookup":
        lookup_server(node, argv[1])
    elif mode == "fibonacci":
        fibonacci_server(node, argv[1], float(argv[2]), reject="--reject" in argv)
    else:
        raise SystemExit(f"unknown mode {mode!r}")


def fibonacci_server(node: Any, action: str, period: float, *, reject: bool) -> None:
    from rclpy.action import ActionServer, CancelResponse, GoalResponse
    from rclpy.callback_groups import ReentrantCallbackGroup
    from rclpy.executors import MultiThreadedExecutor

    Fibonacci = load("test_msgs/action/Fibonacci")

    def on_goal(request: Any) -> Any:
        if reject:
            emit({"rejected": request.order})
            return GoalResponse.REJECT
        emit({"goal": request.order})
        return GoalResponse.ACCEPT

    def execute(handle: Any) -> Any:
        order = handle.request.order
        sequence = [0, 1]
        feedback = Fibonacci.Feedback()
        for i in range(1, order):
            if handle.is_cancel_requested:
                handle.canceled()
                emit({"canceled": order})
                result = Fibonacci.Result()
                result.sequence = sequence
                return result
            sequence.append(sequence[i] + sequence[i - 1])
            feedback.sequence = sequence
            handle.publish_feedback(feedback)
            time.sleep(period)
        handle.succeed()
        emit({"finished": order})
        result = Fibonacci.Result()
        result.sequence = sequence
        return result

    ActionServer(
        node,
        Fibonacci,
        action,
        execute_callback=execute,
        goal_callback=on_goal,
        cancel_callback=lambda _request: CancelResponse.ACCEPT,
        callback_group=ReentrantCallbackGroup(),
    )
    emit({"ready": True})
    executor = MultiThreadedExecutor(num_threads=4)
    executor.add_node(node)
    executor.spin()


def lookup_server(node: Any, action: str) -> None:
    from rclpy.action import ActionServer

    lookup = load("tf2_msgs/action/LookupTransform")

    def execute(handle: Any) -> Any:
        goal = handle.request
        emit({"goal": goal.target_frame})
        for _ in range(2):
            handle.publish_feedback(lookup.Feedback())
            time.sleep(0.05)
        handle.succeed()
        result = lookup.Result()
        result.transform.header.frame_id = goal.target_frame
        result.transform.child_frame_id = goal.source_frame
        result.transform.transform.rotation.w = 1.0
        return result

    ActionServer(node, lookup, action, execute_callback=execute)
    emit({"ready": True})
    rclpy.spin(node)


if __name__ == "__main__":
    with contextlib.suppress(KeyboardInterrupt):
        main(sys.argv[1:])
