"""The planner node: serves niryo_moveit/MoverService on /niryo_moveit with MoverPlanner.

On the local backend it is an in-process `Node` on the endpoint's LocalBus; with ROS 1
it is a real rospy node, run as its own process (see ros1_planner).
A request that cannot be planned gets the tutorial's answer, an empty trajectory list,
and the reason goes to /rosout (rosgraph_msgs/Log, level ERROR) where the caller reads it.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from simbridge.apps.pick_and_place.conversion import pose_from_msg, robot_trajectory_msg
from simbridge.apps.pick_and_place.scene import SCENE_PATH, planning_obstacles
from simbridge.endpoint import LocalBus, Node
from simbridge.errors import PlanningError, SimbridgeError
from simbridge.messages import MessageRegistry, default_registry
from simbridge.planning import MoverPlanner
from simbridge.sim import load_scene

__all__ = [
    "LOG_ERROR",
    "LOG_TOPIC",
    "NODE_NAME",
    "PLANNER_SERVICE",
    "SERVICE_TYPE",
    "LocalPlannerNode",
    "MoverServiceHandler",
    "planner_for_scene",
]

PLANNER_SERVICE = "/niryo_moveit"
SERVICE_TYPE = "niryo_moveit/MoverService"
NODE_NAME = "niryo_moveit_planner"
LOG_TOPIC = "/rosout"
LOG_ERROR = 8
"""rosgraph_msgs/Log.ERROR, the level of the reasons the planner publishes."""

log = logging.getLogger("simbridge.apps.pick_and_place.planner")


def planner_for_scene(scene_path: Path = SCENE_PATH) -> MoverPlanner:
    """A Niryo One MoverPlanner whose planning scene is the static boxes of a scene file."""
    return MoverPlanner.niryo_one(planning_obstacles(load_scene(scene_path)))


class MoverServiceHandler:
    """MoverService requests in, responses out; never raises.

    A request that cannot be planned (unreachable, colliding, malformed) gets an empty
    trajectory list and ``report(reason)``; ``last_error`` keeps the latest reason.
    """

    def __init__(
        self,
        planner: MoverPlanner,
        registry: MessageRegistry,
        report: Callable[[str], None],
    ) -> None:
        self.planner = planner
        self.registry = registry
        self.report = report
        self.last_error: str | None = None
        self._info = registry.service(SERVICE_TYPE)
        self._lock = threading.Lock()

    def __call__(self, request: Any) -> Any:
        """Plan pre-grasp, grasp, pick up and place for one request."""
        response = self.registry.new(self._info.response)
        began = time.perf_counter()
        try:
            joints = np.asarray(request.joints_input.joints, dtype=np.float64)
            pick = pose_from_msg(request.pick_pose)
            place = pose_from_msg(request.place_pose)
            with self._lock:
                plan = self.planner.plan(joints, pick, place)
        except (PlanningError, ValueError) as exc:
            return self._fail(response, f"no valid plan: {exc}")
        except Exception as exc:  # a planner bug must not take the node down
            log.exception("planning failed unexpectedly")
            return self._fail(response, f"planner failed: {type(exc).__name__}: {exc}")
        response.trajectories = [robot_trajectory_msg(self.registry, t) for t in plan.trajectories]
        log.info("planned pick and place in %.3f s", time.perf_counter() - began)
        return response

    def _fail(self, response: Any, reason: str) -> Any:
        self.last_error = reason
        log.warning("%s: %s", PLANNER_SERVICE, reason)
        try:
            self.report(reason)
        except Exception:
            log.exception("could not report a planning error")
        return response

    def serialized(self, payload: bytes) -> bytes:
        """The serialized response to a serialized request (ROS 1 wire format)."""
        try:
            request = self.registry.decode(payload, self._info.request)
        except SimbridgeError as exc:
            return self.registry.encode(
                self._fail(self.registry.new(self._info.response), f"bad request: {exc}")
            )
        return self.registry.encode(self(request), self._info.response)


class LocalPlannerNode:
    """The planner as an in-process node on the endpoint's LocalBus; errors go to /rosout."""

    def __init__(
        self,
        bus: LocalBus,
        scene_path: Path = SCENE_PATH,
        registry: MessageRegistry | None = None,
    ) -> None:
        self.registry = registry or default_registry()
        self.node = Node(bus, f"/{NODE_NAME}", self.registry)
        self._rosout = self.node.advertise(LOG_TOPIC, "rosgraph_msgs/Log")
        self.handler = MoverServiceHandler(
            planner_for_scene(scene_path), self.registry, self._publish_error
        )
        self.node.serve(PLANNER_SERVICE, SERVICE_TYPE, self.handler)

    def _publish_error(self, text: str) -> None:
        now = time.time()
        secs = int(now)
        msg = self.registry.new(
            "rosgraph_msgs/Log",
            level=LOG_ERROR,
            name=f"/{NODE_NAME}",
            msg=text,
            file=__file__,
            function="MoverServiceHandler",
            topics=[LOG_TOPIC],
        )
        msg.header.stamp.sec = secs
        msg.header.stamp.nanosec = int((now - secs) * 1e9)
        self._rosout.publish(msg)

    def close(self) -> None:
        """Withdraw the service and the /rosout publisher."""
        self.node.close()

    def __enter__(self) -> LocalPlannerNode:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
