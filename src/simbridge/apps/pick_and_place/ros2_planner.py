"""The planner as a real ROS 2 node: rclpy serving niryo_moveit/srv/MoverService.

Runs in the ROS 2 venv, where the niryo_moveit interface package is built (`make ros2`
builds the shipped definitions). rclpy services have no raw mode, so a request is
serialized to CDR by rclpy, planned by the same MoverServiceHandler as on the other
backends (with the ROS 2 message layouts), and the CDR answer deserialized by rclpy.
The node has an rclpy context of its own and localhost-only DDS settings (`backends.ros2.env`).
"""

from __future__ import annotations

import importlib
import threading
from pathlib import Path
from typing import Any

import rclpy
import rclpy.executors
from rclpy.serialization import deserialize_message, serialize_message

from simbridge.apps.pick_and_place.planner_node import (
    NODE_NAME,
    PLANNER_SERVICE,
    SERVICE_TYPE,
    MoverServiceHandler,
    planner_for_scene,
)
from simbridge.apps.pick_and_place.scene import SCENE_PATH
from simbridge.endpoint.backends.ros2 import apply_ros2_env
from simbridge.errors import AppError
from simbridge.messages import ros2_registry

__all__ = ["Ros2PlannerNode"]


def _service_class() -> Any:
    package, _, name = SERVICE_TYPE.partition("/")
    try:
        return getattr(importlib.import_module(f"{package}.srv"), name)
    except (ImportError, AttributeError) as exc:
        raise AppError(
            f"no ROS 2 interface {package}/srv/{name} in this venv ({exc}); build it with "
            f"`make ros2` (or `simbridge msg build` on the {package} package)"
        ) from exc


class Ros2PlannerNode:
    """`/niryo_moveit_planner` serving `/niryo_moveit`, spun on a thread; a context manager."""

    def __init__(self, scene_path: Path = SCENE_PATH, node_name: str = NODE_NAME) -> None:
        service_class = _service_class()
        apply_ros2_env()
        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        self.node = rclpy.create_node(node_name, context=self.context)
        self.handler = MoverServiceHandler(
            planner_for_scene(scene_path), ros2_registry(), self.node.get_logger().error
        )
        response_class = service_class.Response

        def on_request(request: Any, _response: Any) -> Any:
            answer = self.handler.serialized(serialize_message(request))
            return deserialize_message(answer, response_class)

        self.node.create_service(service_class, PLANNER_SERVICE, on_request)
        self._executor = rclpy.executors.SingleThreadedExecutor(context=self.context)
        self._executor.add_node(self.node)
        self._thread = threading.Thread(target=self._spin, name="ros2-planner", daemon=True)
        self._thread.start()

    def _spin(self) -> None:
        while self.context.ok():
            try:
                self._executor.spin_once(timeout_sec=0.2)
            except rclpy.executors.ExternalShutdownException:
                return

    def close(self) -> None:
        """Leave the graph and stop spinning."""
        if self.context.ok():
            rclpy.shutdown(context=self.context)
        self._thread.join(5.0)
        self._executor.shutdown(timeout_sec=1.0)
        self.node.destroy_node()

    def __enter__(self) -> Ros2PlannerNode:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
