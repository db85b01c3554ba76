"""The planner node: serves niryo_moveit/MoverService on /niryo_moveit with MoverPlanner.

On the local backend it is an in-process `Node` on the endpoint's LocalBus; with ROS 1
it is a real rospy node, run as its own process:
`python -m simbridge.apps.pick_and_place.planner_node [--scene PATH] [name:=value ...]`.
A request that cannot be planned gets the tutorial's answer, an empty trajectory list,
and the reason goes to /rosout (rosgraph_msgs/Log, level ERROR) where the caller reads it.
"""

from __future__ import annotations

import argparse
import logging
import sys
import threading
import time
from collections.abc import Callable, Sequence
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
    "main",
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


def _serve_ros1(scene_path: Path, args: Sequence[str], connect_timeout: float) -> None:
    """Join the ROS master as /niryo_moveit_planner and serve until interrupted."""
    import rospy  # noqa: PLC0415 - ROS 1 is optional

    from simbridge.endpoint.backends.ros1_node import join_graph  # noqa: PLC0415
    from simbridge.endpoint.backends.ros1_raw import RawMessage, raw_service_class  # noqa: PLC0415
    from simbridge.endpoint.backends.ros1_types import Ros1Types  # noqa: PLC0415

    registry = default_registry()
    handler = MoverServiceHandler(planner_for_scene(scene_path), registry, rospy.logerr)
    service_class = raw_service_class(Ros1Types(registry).service(SERVICE_TYPE))

    def on_request(request: RawMessage) -> RawMessage:
        return service_class._response_class(handler.serialized(request.payload))

    join_graph(NODE_NAME, args, connect_timeout)
    server = rospy.Service(PLANNER_SERVICE, service_class, on_request)
    rospy.loginfo("serving %s [%s]", PLANNER_SERVICE, SERVICE_TYPE)
    print(f"{NODE_NAME}: serving {PLANNER_SERVICE} [{SERVICE_TYPE}]", flush=True)
    try:
        while not rospy.is_shutdown():
            time.sleep(0.2)
    except KeyboardInterrupt:
        pass
    finally:
        server.shutdown("planner node stopping")
        rospy.signal_shutdown("planner node stopping")


def main(argv: Sequence[str] | None = None) -> int:
    """Run the planner as a ROS 1 node (ROS args such as __master:=URI pass through)."""
    args = list(sys.argv[1:] if argv is None else argv)
    parser = argparse.ArgumentParser(
        prog="python -m simbridge.apps.pick_and_place.planner_node",
        description=f"Serve {SERVICE_TYPE} on {PLANNER_SERVICE} as a ROS 1 node.",
    )
    parser.add_argument("--scene", type=Path, default=SCENE_PATH, help="scene YAML (obstacles)")
    parser.add_argument("--connect-timeout", type=float, default=10.0, metavar="S")
    options, ros_args = parser.parse_known_args([a for a in args if ":=" not in a])
    if ros_args:
        parser.error(f"unrecognised arguments: {' '.join(ros_args)}")
    logging.basicConfig(level=logging.INFO, format="%(name)s: %(message)s")
    try:
        _serve_ros1(options.scene, [a for a in args if ":=" in a], options.connect_timeout)
    except SimbridgeError as exc:
        print(f"{NODE_NAME}: {exc}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
