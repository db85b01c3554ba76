"""A ROS 2 action client for the tests, run with the ROS 2 venv's Python (never imported by
pytest): plain rclpy ActionClients driven by JSON commands on stdin, one JSON object per
line on stdout. Every rclpy call runs on the executor's thread (a timer takes the commands).

    {"op": "wait", "action": A, "type": "pkg/action/T"}  ->  {"ready": A, "ok": bool}
    {"op": "goal", "tag": G, "action": A, "type": T, "goal": {...}}
        ->  {"accepted": G, "ok": bool, "goal_id": hex UUID}, then {"result": G,
            "status": s, "values": {...}, "feedback": n}, and {"feedback": G,
            "joint_names": [...], "values": {...}} at the first feedback
    {"op": "cancel", "tag": G}  ->  {"cancel": G, "return_code": rc, "canceling": n}
    {"op": "joints", "topic": T}  ->  {"joints": {name: position}} (the next JointState)
    {"op": "state", "topic": T}  ->  {"state": {...}} (the next controller state)
    {"op": "status", "action": A}  ->  {"status": A, "goals": {hex UUID: status}} (the
        next goal status array the action's server publishes, its latest when it is quiet)
    {"op": "type_hashes", "topic": T}  ->  {"type_hashes": T, "hashes": ["RIHS01_...", ...]}
        (the type hash each publisher of T announces on the graph)
"""

from __future__ import annotations

import json
import queue
import sys
import threading
import uuid
from typing import Any

import rclpy
from rclpy.action import ActionClient
from rclpy.action.client import ClientGoalHandle
from rclpy.qos import qos_profile_action_status_default
from ros2_node import (  # type: ignore[import-not-found]  # the script beside this one
    emit,
    load,
    message_to_ordereddict,
)


def fill(msg: Any, values: dict[str, Any]) -> Any:
    """Set `msg`'s fields from JSON data: nested messages from dicts, sequences of messages
    from lists of dicts."""
    types = msg.get_fields_and_field_types()
    for key, value in values.items():
        kind = types[key]
        if isinstance(value, dict):
            fill(getattr(msg, key), value)
        elif isinstance(value, list) and kind.startswith("sequence<") and "/" in kind:
            package, name = kind[len("sequence<") : -1].split("/")
            cls = load(f"{package}/msg/{name}")
            setattr(msg, key, [fill(cls(), item) for item in value])
        else:
            setattr(msg, key, value)
    return msg


def type_of_goal_id(cls: Any) -> Any:
    """The UUID message class of action `cls`'s goal ids."""
    return type(cls.Impl.SendGoalService.Request().goal_id)


class Driver:
    def __init__(self, node: Any) -> None:
        self.node = node
        self.commands: queue.Queue[dict[str, Any]] = queue.Queue()
        self.clients: dict[str, Any] = {}
        self.handles: dict[str, Any] = {}
        self.waiting: dict[str, tuple[str, Any]] = {}
        node.create_timer(0.02, self.drain)

    def client(self, action: str, type_name: str) -> Any:
        if action not in self.clients:
            self.clients[action] = ActionClient(self.node, load(type_name), action)
        return self.clients[action]

    def drain(self) -> None:
        while True:
            try:
                command = self.commands.get_nowait()
            except queue.Empty:
                return
            getattr(self, f"op_{command.pop('op')}")(**command)

    def op_wait(self, action: str, type: str) -> None:
        """Ready once the server is discovered and has answered a result request for an
        unknown goal (its responses then reach us: a response written before our reader
        matched would be lost)."""
        client = self.client(action, type)
        cls = load(type)
        uuid_class = type_of_goal_id(cls)
        answered = threading.Event()

        def poll() -> None:
            if answered.is_set():
                timer.cancel()
                emit({"ready": action, "ok": True})
            elif client.server_is_ready():
                accepted = cls.Impl.SendGoalService.Response(accepted=True)
                probe = ClientGoalHandle(
                    client, uuid_class(uuid=list(uuid.uuid4().bytes)), accepted
                )
                probe.get_result_async().add_done_callback(lambda _f: answered.set())

        timer = self.node.create_timer(0.25, poll)

    def op_goal(self, tag: str, action: str, type: str, goal: dict[str, Any]) -> None:
        client = self.client(action, type)
        message = fill(load(type).Goal(), goal)
        counts = {"feedback": 0}

        def on_feedback(msg: Any) -> None:
            counts["feedback"] += 1
            if counts["feedback"] == 1:
                names = list(getattr(msg.feedback, "joint_names", []))
                values = message_to_ordereddict(msg.feedback)
                emit({"feedback": tag, "joint_names": names, "values": values})

        def on_result(future: Any) -> None:
            response = future.result()
            emit(
                {
                    "result": tag,
                    "status": int(response.status),
                    "values": message_to_ordereddict(response.result),
                    "feedback": counts["feedback"],
                }
            )

        def on_response(future: Any) -> None:
            handle = future.result()
            goal_id = bytes(handle.goal_id.uuid).hex()
            emit({"accepted": tag, "ok": bool(handle.accepted), "goal_id": goal_id})
            if handle.accepted:
                self.handles[tag] = handle
                handle.get_result_async().add_done_callback(on_result)

        client.send_goal_async(message, feedback_callback=on_feedback).add_done_callback(
            on_response
        )

    def op_cancel(self, tag: str) -> None:
        def answered(future: Any) -> None:
            response = future.result()
            emit(
                {
                    "cancel": tag,
                    "return_code": int(response.return_code),
                    "canceling": len(response.goals_canceling),
                }
            )

        self.handles[tag].cancel_goal_async().add_done_callback(answered)

    def _next_message(self, topic: str, type_name: str, out: Any) -> None:
        def once(msg: Any) -> None:
            if holder:
                self.node.destroy_subscription(holder.pop())
                emit(out(msg))

        holder = [self.node.create_subscription(load(type_name), topic, once, 10)]

    def op_joints(self, topic: str) -> None:
        self._next_message(
            topic,
            "sensor_msgs/msg/JointState",
            lambda m: {"joints": dict(zip(m.name, (float(p) for p in m.position), strict=False))},
        )

    def op_state(self, topic: str) -> None:
        self._next_message(
            topic,
            "control_msgs/msg/JointTrajectoryControllerState",
            lambda m: {"state": message_to_ordereddict(m)},
        )

    def op_status(self, action: str) -> None:
        def once(msg: Any) -> None:
            if holder:
                self.node.destroy_subscription(holder.pop())
                goals = {
                    bytes(s.goal_info.goal_id.uuid).hex(): int(s.status) for s in msg.status_list
                }
                emit({"status": action, "goals": goals})

        holder = [
            self.node.create_subscription(
                load("action_msgs/msg/GoalStatusArray"),
                f"{action}/_action/status",
                once,
                qos_profile_action_status_default,
            )
        ]

    def op_type_hashes(self, topic: str) -> None:
        infos = self.node.get_publishers_info_by_topic(topic)
        emit({"type_hashes": topic, "hashes": [str(i.topic_type_hash) for i in infos]})


def main() -> None:
    rclpy.init()
    node = rclpy.create_node("simbridge_test_action_driver")
    driver = Driver(node)

    def read() -> None:
        for line in sys.stdin:
            if line.strip():
                driver.commands.put(json.loads(line))

    threading.Thread(target=read, daemon=True).start()
    emit({"up": True})
    try:
        rclpy.spin(node)
    except KeyboardInterrupt:
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    main()
