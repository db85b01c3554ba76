"""`simbridge planner`: the pick-and-place MoverService planner on its own, as a ROS node.

With `--backend ros1` it is a rospy node serving /niryo_moveit to the ROS graph
(`rosservice call`, a rospy client, or a sim through `simbridge endpoint --backend ros1`).
With `--backend ros2` it is an rclpy node (in the ROS 2 venv; localhost-only DDS)
serving /niryo_moveit to the ROS 2 graph.
With `--backend local` it runs an endpoint on the embedded bus with the planner on it,
so a ROS-TCP client (a Unity scene, a connector) can call /niryo_moveit with no ROS.
"""

from __future__ import annotations

import argparse
import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from .common import ensure_ros1, reexec_in_ros2_venv

__all__ = ["add_parser"]


@contextmanager
def _stop_on_signals() -> Iterator[threading.Event]:
    """An event set by SIGINT or SIGTERM, so both end the planner cleanly (unregistered).

    The handler sets it from a thread of its own: Python runs handlers in the main thread
    between bytecodes, possibly inside `stop.wait()` while that holds the event's lock, and
    `stop.set()` there would wait for that lock forever. Wait for it with `wait_for_stop`.
    """
    stop = threading.Event()

    def handle(_sig: int, _frame: object) -> None:
        threading.Thread(target=stop.set, name="simbridge-planner-stop", daemon=True).start()

    previous = {sig: signal.signal(sig, handle) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield stop
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


def wait_for_stop(stop: threading.Event) -> None:
    """Block until `stop` is set, waking every 0.2 s to let signal handlers run.

    CPython runs a signal's Python handler only when the main thread next runs bytecode; a
    signal that lands while that thread is on its way into a lock wait (handing the GIL to a
    busy rospy thread) leaves it asleep with the handler pending: 2 of 5 SIGTERMs sent just
    as the ROS 1 planner started serving were never handled with a plain `stop.wait()`.
    """
    while not stop.wait(0.2):
        pass


def run_planner(args: argparse.Namespace) -> int:
    if args.backend == "ros1":
        ensure_ros1()
    from simbridge.apps.pick_and_place.planner_node import PLANNER_SERVICE, SERVICE_TYPE
    from simbridge.apps.pick_and_place.scene import SCENE_PATH

    scene: Path = args.scene or SCENE_PATH
    if args.backend == "ros2":
        reexec_in_ros2_venv()
    with _stop_on_signals() as stop:
        if args.backend == "ros2":
            from simbridge.apps.pick_and_place.ros2_planner import Ros2PlannerNode

            with Ros2PlannerNode(scene, node_name=args.node_name.lstrip("/")):
                print(
                    f"simbridge planner: serving {PLANNER_SERVICE} [{SERVICE_TYPE}] as ROS 2 "
                    f"node /{args.node_name.lstrip('/')}",
                    flush=True,
                )
                wait_for_stop(stop)
            return 0
        if args.backend == "ros1":
            from simbridge.apps.pick_and_place.ros1_planner import serve

            serve(
                scene,
                stop,
                args.ros_args,
                node_name=args.node_name,
                connect_timeout=args.connect_timeout,
            )
            return 0
        from simbridge.apps.pick_and_place.planner_node import LocalPlannerNode
        from simbridge.endpoint import EndpointOptions, EndpointThread, LocalBus

        bus = LocalBus()
        options = EndpointOptions(host=args.host, port=args.port)
        with EndpointThread(options, bus) as endpoint, LocalPlannerNode(bus, scene):
            print(
                f"simbridge planner: serving {PLANNER_SERVICE} [{SERVICE_TYPE}] on the endpoint "
                f"{args.host}:{endpoint.port} (local bus)",
                flush=True,
            )
            wait_for_stop(stop)
    return 0


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    planner = sub.add_parser(
        "planner",
        help="serve the pick-and-place planner (niryo_moveit/MoverService on /niryo_moveit)",
        description="Serve niryo_moveit/MoverService on /niryo_moveit: plans pre-grasp, "
        "grasp, pick-up and place trajectories for the Niryo One arm around the scene's "
        "static boxes. Unplannable requests get an empty answer and the reason on /rosout.",
    )
    planner.add_argument(
        "--backend",
        choices=["ros1", "ros2", "local"],
        default="ros1",
        help="ros1 (default): a rospy node on ROS_MASTER_URI; ros2: an rclpy node (ROS 2 "
        "venv); local: an endpoint on the embedded bus that ROS-TCP clients connect to",
    )
    planner.add_argument(
        "--scene",
        type=Path,
        default=None,
        help="scene YAML whose static boxes are obstacles (default: the pick-and-place scene)",
    )
    planner.add_argument(
        "--node-name", default="niryo_moveit_planner", help="ROS node name (ros1, ros2)"
    )
    planner.add_argument(
        "--connect-timeout",
        type=float,
        default=10.0,
        metavar="S",
        help="how long to wait for the master (ros1)",
    )
    planner.add_argument("--host", default="127.0.0.1", help="endpoint address (local)")
    planner.add_argument(
        "--port", type=int, default=10000, help="endpoint port (local; 0 = any free port)"
    )
    planner.set_defaults(func=run_planner)
