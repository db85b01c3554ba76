"""The planner as a real ROS 1 node, in a process of its own (rospy allows one node each).

`python -m simbridge.apps.pick_and_place.ros1_planner [--scene PATH] [name:=value ...]`
joins the master (ROS_MASTER_URI, or __master:=) as /niryo_moveit_planner and serves
niryo_moveit/MoverService on /niryo_moveit with raw rospy classes built from the message
registry (no niryo_moveit Python module needed); reasons for empty answers go to /rosout.
"""

from __future__ import annotations

import argparse
import logging
import sys
import time
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
from simbridge.apps.pick_and_place.scene import SCENE_PATH
from simbridge.endpoint.backends.ros1_node import join_graph
from simbridge.endpoint.backends.ros1_raw import RawMessage, raw_service_class
from simbridge.endpoint.backends.ros1_types import Ros1Types
from simbridge.errors import SimbridgeError
from simbridge.messages import default_registry

__all__ = ["main", "serve"]


def serve(scene_path: Path, args: Sequence[str], connect_timeout: float) -> None:
    """Join the ROS master as /niryo_moveit_planner and serve until interrupted."""
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
        prog="python -m simbridge.apps.pick_and_place.ros1_planner",
        description=f"Serve {SERVICE_TYPE} on {PLANNER_SERVICE} as a ROS 1 node.",
    )
    parser.add_argument("--scene", type=Path, default=SCENE_PATH, help="scene YAML (obstacles)")
    parser.add_argument("--connect-timeout", type=float, default=10.0, metavar="S")
    options, ros_args = parser.parse_known_args([a for a in args if ":=" not in a])
    if ros_args:
        parser.error(f"unrecognised arguments: {' '.join(ros_args)}")
    logging.basicConfig(level=logging.INFO, format="%(name)s: %(message)s")
    try:
        serve(options.scene, [a for a in args if ":=" in a], options.connect_timeout)
    except SimbridgeError as exc:
        print(f"{NODE_NAME}: {exc}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
