"""The planner as a real ROS 1 node, in a process of its own (rospy allows one node each).

`simbridge planner --backend ros1` joins the master (ROS_MASTER_URI, or __master:=) as
/niryo_moveit_planner and serves niryo_moveit/MoverService on /niryo_moveit with raw rospy
classes built from the message registry (no niryo_moveit Python module needed); reasons
for empty answers go to /rosout.
"""

from __future__ import annotations

import threading
from collections.abc import Sequence
from pathlib import Path

import rospy

from simbridge.apps.pick_and_place.planner_node import (
    NODE_NAME,
    PLANNER_SERVICE,
    SERVICE_TYPE,
    MoverServiceHandler,
    planner_for_scene,
)
from simbridge.endpoint.backends.ros1 import (
    RawMessage,
    Ros1Types,
    join_graph,
    on_node_shutdown,
    raw_service_class,
)
from simbridge.errors import AppError
from simbridge.messages import default_registry

__all__ = ["serve"]


def serve(
    scene_path: Path,
    stop: threading.Event,
    args: Sequence[str] = (),
    *,
    node_name: str = NODE_NAME,
    connect_timeout: float = 10.0,
) -> None:
    """Join the ROS master as `node_name` and serve until `stop` is set.

    Leaving unregisters the service and the node. Raises AppError when the master shut
    the node down (another node registered with the same name).
    """
    registry = default_registry()
    handler = MoverServiceHandler(planner_for_scene(scene_path), registry, rospy.logerr)
    service_class = raw_service_class(Ros1Types(registry).service(SERVICE_TYPE))

    def on_request(request: RawMessage) -> RawMessage:
        return service_class._response_class(handler.serialized(request.payload))

    join_graph(node_name, args, connect_timeout)
    shut_down: list[str] = []

    def on_shutdown(reason: str) -> None:
        shut_down.append(reason)
        stop.set()

    on_node_shutdown(on_shutdown)
    server = rospy.Service(PLANNER_SERVICE, service_class, on_request)
    rospy.loginfo("serving %s [%s]", PLANNER_SERVICE, SERVICE_TYPE)
    print(f"{rospy.get_name()}: serving {PLANNER_SERVICE} [{SERVICE_TYPE}]", flush=True)
    try:
        while not stop.wait(0.2):  # in slices, so a signal's handler runs (cli.planner says why)
            pass
    finally:
        external = list(shut_down)
        server.shutdown("planner node stopping")
        rospy.signal_shutdown("planner node stopping")
    if external:
        raise AppError(f"the ROS node {rospy.get_name()} was shut down: {external[0]}")
