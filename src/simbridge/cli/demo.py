"""`simbridge demo`: the demos end to end."""

from __future__ import annotations

import argparse

from .common import reexec_in_ros2_venv

__all__ = ["add_parser"]


def run_demo(args: argparse.Namespace) -> int:
    if args.backend == "ros2":
        reexec_in_ros2_venv()
    if args.name == "bridge":
        from simbridge.apps.bridge_demo import run_bridge_demo

        return 0 if run_bridge_demo(backend=args.backend) else 1
    if args.name == "mobile-robot":
        from simbridge.apps.mobile_robot import main as mobile_robot_main

        forwarded = ["--side", str(args.side), "--realtime", str(args.realtime or 0.0)]
        forwarded += ["--backend", args.backend]
        if args.record:
            forwarded += ["--record", args.record]
        if args.view:
            forwarded += ["--view", "--view-port", str(args.view_port)]
        return mobile_robot_main([*forwarded, "--json"] if args.json else forwarded)
    from simbridge.apps import pick_and_place_main

    forwarded = ["--backend", args.backend]
    if args.json:
        forwarded.append("--json")
    if args.video:
        forwarded += ["--video", args.video]
    if args.seed is not None:
        forwarded += ["--seed", str(args.seed)]
    return pick_and_place_main(forwarded)


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    demo = sub.add_parser("demo", help="run a demo end to end (embedded bus or ROS 1)")
    demo.add_argument(
        "name",
        nargs="?",
        default="pick-and-place",
        choices=["pick-and-place", "mobile-robot", "bridge"],
        help="pick-and-place (default): a Niryo One arm planned by a MoverService; "
        "mobile-robot: a diff-drive robot with lidar, camera, IMU and odometry drives a square; "
        "bridge: two connectors exchange Twist messages and a service call",
    )
    demo.add_argument(
        "--backend",
        choices=["local", "ros1", "ros2"],
        default="local",
        help="every demo: local (the embedded bus, no ROS needed) or ros1 (real ROS topics and "
        "services on the master at ROS_MASTER_URI, else a private roscore); mobile-robot and "
        "pick-and-place: ros2 (real ROS 2 topics and services, localhost-only DDS, in the "
        "ROS 2 venv)",
    )
    demo.add_argument(
        "--json",
        action="store_true",
        help='pick-and-place: print {"success", "cube_error_m", "phases"} last',
    )
    demo.add_argument("--video", metavar="PATH", help="pick-and-place: write a .gif (or .mp4)")
    demo.add_argument("--seed", type=int, help="pick-and-place: random cube and target")
    demo.add_argument("--side", type=float, default=1.0, help="mobile-robot: square side (m)")
    demo.add_argument(
        "--realtime",
        type=float,
        default=0.0,
        help="mobile-robot: pace at this real-time factor (0 = flat out)",
    )
    demo.add_argument(
        "--record", metavar="FILE", help="mobile-robot: record every sim topic (.mcap or .bag)"
    )
    demo.add_argument(
        "--view", action="store_true", help="mobile-robot: live 3D view in the browser (viser)"
    )
    demo.add_argument("--view-port", type=int, default=8080, help="live view port (default 8080)")
    demo.set_defaults(func=run_demo)
