"""The line's robots driven from a ROS 2 process of their own: plain rclpy ActionClients of
the controllers' control_msgs actions (served by the sim through a `--backend ros2`
endpoint), `<ns>/joint_states` subscriptions, the sim's pause service and /clock.

`python -m simbridge.apps.line.ros2_cells --seed S --parts N --pause SERVICE` runs the same
`LineSupervisor` and cells as the other backends over a `Ros2Graph`, prints the progress
lines, then one JSON line `{"line_cells": {...}}` (first goal and last delivery in sim time,
planning time, per-robot tallies, the error if a step failed). Runs in the ROS 2 venv;
messages are built with simbridge's ROS 2 registry and cross to rclpy as CDR.
"""

from __future__ import annotations

import argparse
import importlib
import json
import sys
import threading
import time
import uuid
from collections.abc import Callable, Sequence
from typing import Any

import rclpy
import rclpy.executors
from rclpy.action import ActionClient
from rclpy.action.client import ClientGoalHandle
from rclpy.serialization import deserialize_message, serialize_message

from simbridge.apps.line.cells import ArmCell, ConveyorCell, GoalClient
from simbridge.apps.line.scene import ARMS, CONVEYOR
from simbridge.apps.line.supervisor import LineSupervisor
from simbridge.apps.line.task import LineTask
from simbridge.connector.ros2_actions import ACTIONLIB_STATUS
from simbridge.endpoint.backends.ros2 import apply_ros2_env
from simbridge.errors import AppError, SimbridgeError
from simbridge.messages import MessageRegistry, ros2_registry
from simbridge.messages.actionlib import REJECTED

__all__ = ["RESULT_KEY", "Ros2Graph", "main"]

RESULT_KEY = "line_cells"
"""The key of the JSON line this process ends with."""
_PROBE_EVERY = 0.25


def _interface(name: str, kind: str) -> Any:
    """The rclpy class of `pkg/Name` (`kind` msg, srv or action)."""
    package, base = name.split("/")
    try:
        return getattr(importlib.import_module(f"{package}.{kind}"), base)
    except (ImportError, AttributeError) as exc:
        raise AppError(
            f"no ROS 2 interface {package}/{kind}/{base} in this venv ({exc}); `make ros2` "
            "builds the shipped ones"
        ) from exc


class _Goal:
    """A goal sent by a `_Client` (a `cells.GoalHandle`): actionlib's status values."""

    def __init__(self, client: _Client) -> None:
        self._client = client
        self.status: int | None = None
        self.result: Any = None
        self.text = ""
        self.handle: Any = None
        self._done = threading.Event()

    def wait(self, timeout: float | None = None) -> bool:
        return self._done.wait(timeout)

    def cancel(self) -> None:
        handle = self.handle
        if handle is not None:
            self._client.graph.on_rclpy(handle.cancel_goal_async)

    def end(self, status: int, result: Any, text: str = "") -> None:
        self.status, self.result, self.text = status, result, text
        self._done.set()


class _Client:
    """One rclpy ActionClient behind `cells.GoalClient`'s face."""

    def __init__(self, graph: Ros2Graph, name: str, action_type: str) -> None:
        self.graph = graph
        self._name = name
        self._type = action_type
        self._cls = _interface(action_type, "action")
        self._rclpy = graph.call(lambda: ActionClient(graph.node, self._cls, name))

    @property
    def name(self) -> str:
        return self._name

    def wait_for_server(self, timeout: float | None = None) -> bool:
        """Discovered, and has answered a result request for a goal it does not know (so its
        answers reach us: a DDS service response written before our reader matched is lost)."""
        deadline = None if timeout is None else time.monotonic() + timeout
        answered = threading.Event()
        uuid_class = type(self._cls.Impl.SendGoalService.Request().goal_id)

        def probe() -> None:
            if not self._rclpy.server_is_ready():
                return
            accepted = self._cls.Impl.SendGoalService.Response(accepted=True)
            unknown = ClientGoalHandle(
                self._rclpy, uuid_class(uuid=list(uuid.uuid4().bytes)), accepted
            )
            unknown.get_result_async().add_done_callback(lambda _f: answered.set())

        while not answered.is_set():
            if deadline is not None and time.monotonic() >= deadline:
                return False
            self.graph.on_rclpy(probe)
            answered.wait(_PROBE_EVERY)
        return True

    def send_goal(self, goal: Any, on_feedback: Callable[[Any], None] | None = None) -> _Goal:
        """Send `goal` (a message of the ROS 2 registry) as CDR through rclpy."""
        registry = self.graph.registry
        message = deserialize_message(
            registry.encode(goal, f"{self._type}Goal", fmt="cdr"), self._cls.Goal
        )
        sent = _Goal(self)

        def on_result(future: Any) -> None:
            response = future.result()
            data = bytes(serialize_message(response.result))
            result = registry.decode(data, f"{self._type}Result", fmt="cdr")
            status = ACTIONLIB_STATUS.get(int(response.status), int(response.status))
            sent.end(status, result)

        def on_response(future: Any) -> None:
            handle = future.result()
            if not handle.accepted:
                sent.end(REJECTED, None, "the server rejected the goal")
                return
            sent.handle = handle
            handle.get_result_async().add_done_callback(on_result)

        def send() -> None:
            feedback = (lambda m: on_feedback(m.feedback)) if on_feedback is not None else None
            self._rclpy.send_goal_async(message, feedback_callback=feedback).add_done_callback(
                on_response
            )

        self.graph.on_rclpy(send)
        return sent


class Ros2Graph:
    """A `cells.CellGraph` over one rclpy node spun on a thread of its own; every rclpy call
    runs there (rclpy's action clients are not thread-safe)."""

    def __init__(self, node_name: str = "line_cells") -> None:
        self.registry: MessageRegistry = ros2_registry()
        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        self.node = rclpy.create_node(node_name, context=self.context)
        self.executor = rclpy.executors.SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self._thread = threading.Thread(target=self._spin, name="line-rclpy", daemon=True)
        self._thread.start()
        self.sim_s = 0.0
        """The latest /clock (the sim's time), s."""
        clock = _interface("rosgraph_msgs/Clock", "msg")
        self.call(lambda: self.node.create_subscription(clock, "/clock", self._on_clock, 1))

    def _spin(self) -> None:
        while self.context.ok():
            try:
                self.executor.spin_once(timeout_sec=0.2)
            except (rclpy.executors.ExternalShutdownException, rclpy.executors.ShutdownException):
                return

    def _on_clock(self, msg: Any) -> None:
        self.sim_s = msg.clock.sec + msg.clock.nanosec * 1e-9

    def on_rclpy(self, fn: Callable[[], Any]) -> None:
        """Run `fn` on the rclpy thread."""
        self.executor.create_task(fn)

    def call(self, fn: Callable[[], Any], timeout: float = 30.0) -> Any:
        """Run `fn` on the rclpy thread and return its value."""
        done = threading.Event()
        box: list[Any] = []

        def run() -> None:
            try:
                box.append((fn(), None))
            except Exception as exc:
                box.append((None, exc))
            done.set()

        self.on_rclpy(run)
        if not done.wait(timeout):
            raise AppError(f"the rclpy thread did not answer within {timeout:g} s")
        value, error = box[0]
        if error is not None:
            raise AppError(f"rclpy: {error}") from error
        return value

    def action_client(self, name: str, action_type: str) -> GoalClient:
        return _Client(self, name, action_type)

    def subscribe(self, topic: str, msg_type: str, callback: Callable[[Any], None]) -> None:
        cls = _interface(msg_type, "msg")
        self.call(lambda: self.node.create_subscription(cls, topic, callback, 1))

    def set_paused(self, service: str, paused: bool, timeout: float = 30.0) -> None:
        """Pause (True) or resume the simulation through its std_srvs/SetBool `service`."""
        cls = _interface("std_srvs/SetBool", "srv")
        client = self.call(lambda: self.node.create_client(cls, service))
        answered = threading.Event()
        box: list[Any] = []
        try:
            deadline = time.monotonic() + timeout
            while not client.service_is_ready():
                if time.monotonic() > deadline:
                    raise AppError(f"no service {service} within {timeout:g} s")
                time.sleep(0.01)

            def answer(future: Any) -> None:
                box.append(future.result())
                answered.set()

            def ask() -> None:
                client.call_async(cls.Request(data=paused)).add_done_callback(answer)

            self.on_rclpy(ask)
            if not answered.wait(timeout):
                raise AppError(f"{service} did not answer data={paused} within {timeout:g} s")
        finally:
            self.call(lambda: self.node.destroy_client(client))
        if not box[0].success:
            raise AppError(f"{service} refused data={paused}: {box[0].message}")

    def close(self) -> None:
        """Nothing per robot: the node is shared and goes with `shutdown`."""

    def shutdown(self) -> None:
        """Leave the graph and stop the rclpy thread."""
        try:
            rclpy.shutdown(context=self.context)
        except Exception as exc:  # already shut down (a signal)
            print(f"[line] rclpy shutdown: {exc}", file=sys.stderr)
        self._thread.join(5)
        self.executor.shutdown(timeout_sec=1.0)
        self.node.destroy_node()


def run_cells(
    task: LineTask, pause_service: str, seed: int, *, ready_s: float = 60.0
) -> dict[str, Any]:
    """Move every part of `task` through the ROS 2 graph; the summary for the JSON line."""
    apply_ros2_env()
    graph = Ros2Graph()
    error: str | None = None
    try:
        arm_in = ArmCell(graph, f"/{ARMS[0]}")
        arm_out = ArmCell(graph, f"/{ARMS[1]}")
        conveyor = ConveyorCell(graph, f"/{CONVEYOR}")
        cells = {ARMS[0]: arm_in, ARMS[1]: arm_out, CONVEYOR: conveyor}
        supervisor = LineSupervisor(
            task, arm_in, arm_out, conveyor,
            lambda paused: graph.set_paused(pause_service, paused),
            sim_time=lambda: graph.sim_s, progress=lambda line: print(line, flush=True),
            seed=seed,
        )  # fmt: skip
        try:
            # The sim waits, paused, until every action server answered (none needs time
            # to pass), so the run starts at once; joint states come once it runs.
            for cell in cells.values():
                for client in cell.clients():
                    if not client.wait_for_server(ready_s):
                        raise AppError(
                            f"action server {client.name} did not answer in {ready_s:g} s"
                        )
            graph.set_paused(pause_service, False)
            for cell in cells.values():
                cell.wait_ready(ready_s)
            print("[line] ROS 2 cells ready: every controller's action server answered", flush=True)
            supervisor.run()
        except SimbridgeError as exc:
            error = str(exc)
        return {
            "first_goal_at": supervisor.first_goal_at,
            "last_delivery_at": supervisor.last_delivery_at,
            "planning_wall_s": supervisor.planning_wall_s,
            "robots": {name: cell.tally().to_dict() for name, cell in cells.items()},
            "error": error,
        }
    finally:
        graph.shutdown()


def main(argv: Sequence[str] | None = None) -> int:
    """The cells' process: 0 when every step succeeded, 1 if one failed."""
    parser = argparse.ArgumentParser(prog="python -m simbridge.apps.line.ros2_cells")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--parts", type=int, default=3)
    parser.add_argument("--pause", default="/simbridge/pause", help="the sim's pause service")
    args = parser.parse_args(argv)
    summary = run_cells(LineTask.random(args.seed, args.parts), args.pause, args.seed)
    print(json.dumps({RESULT_KEY: summary}), flush=True)
    return 0 if summary["error"] is None else 1


if __name__ == "__main__":
    sys.exit(main())
