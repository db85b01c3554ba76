"""`simbridge demo`: the demos end to end."""

from __future__ import annotations

import argparse
import sys

from .common import reexec_in_ros2_venv

__all__ = ["add_parser"]


def run_demo(args: argparse.Namespace) -> int:
    if args.name == "line":  # local or ros1 only: decided before any ROS 2 re-exec
        return _run_line(args)
    if args.backend == "ros2":
        reexec_in_ros2_venv()
    if args.name == "bridge":
        if args.view or args.record:
            print(
                "simbridge demo bridge: --view and --record need a simulation; the bridge demo "
                "has none (use pick-and-place, mobile-robot or line)",
                file=sys.stderr,
            )
            return 2
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
    if args.realtime is not None:
        forwarded += ["--realtime", str(args.realtime)]
    if args.record:
        forwarded += ["--record", args.record]
    if args.view:
        forwarded += ["--view", "--view-port", str(args.view_port)]
    return pick_and_place_main(forwarded)


def _run_line(args: argparse.Namespace) -> int:
    from simbridge.apps.line import main as line_main

    if args.backend == "ros2":
        print(
            "simbridge demo line: --backend ros2 is not supported (the controllers speak "
            "ROS 1 actions); use --backend local or ros1",
            file=sys.stderr,
        )
        return 2
    forwarded = ["--backend", args.backend, "--parts", str(args.parts)]
    if args.realtime is not None:
        forwarded += ["--realtime", str(args.realtime)]
    if args.seed is not None:
        forwarded += ["--seed", str(args.seed)]
    if args.video:
        forwarded += ["--video", args.video]
    if args.record:
        forwarded += ["--record", args.record]
    if args.view:
        forwarded += ["--view", "--view-port", str(args.view_port)]
    return line_main([*forwarded, "--json"] if args.json else forwarded)


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    demo = sub.add_parser("demo", help="run a demo end to end (embedded bus or ROS 1)")
    demo.add_argument(
        "name",
        nargs="?",
        default="pick-and-place",
        choices=["pick-and-place", "mobile-robot", "bridge", "line"],
        help="pick-and-place (default): a Niryo One arm planned by a MoverService; "
        "mobile-robot: a diff-drive robot with lidar, camera, IMU and odometry drives a square; "
        "bridge: two connectors exchange Twist messages and a service call; "
        "line: two arms and a conveyor, each in its own namespace, move parts through "
        "their controllers' actions",
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
        help='pick-and-place: print {"success", "cube_error_m", "phases"} last; line: '
        '{"success", "parts", "delivered", "placement_error_m", "cycle_s", ...}',
    )
    demo.add_argument(
        "--video", metavar="PATH", help="pick-and-place, line: write a .gif (or .mp4)"
    )
    demo.add_argument(
        "--seed", type=int, help="pick-and-place: random cube and target; line: part poses"
    )
    demo.add_argument("--parts", type=int, default=3, help="line: parts to move (1 to 4)")
    demo.add_argument("--side", type=float, default=1.0, help="mobile-robot: square side (m)")
    demo.add_argument(
        "--realtime",
        type=float,
        default=None,
        help="mobile-robot, pick-and-place, line: pace at this real-time factor (0 = flat "
        "out; default 0, pick-and-place and line with --view 1)",
    )
    demo.add_argument(
        "--record",
        metavar="FILE",
        help="mobile-robot, line, pick-and-place: record every sim topic (.mcap or .bag)",
    )
    demo.add_argument(
        "--view",
        action="store_true",
        help="mobile-robot, line, pick-and-place: live 3D view in the browser (viser); "
        "pick-and-place keeps serving with a 'run again' button until Ctrl-C",
    )
    demo.add_argument("--view-port", type=int, default=8080, help="live view port (default 8080)")
    demo.set_defaults(func=run_demo)
