"""`simbridge demo NAME`: the demos end to end, each with its own options
(`simbridge demo NAME --help`); `simbridge demo` alone runs pick-and-place."""

from __future__ import annotations

import argparse
from collections.abc import Iterable

from .common import ensure_ros1, reexec_in_ros2_venv

__all__ = ["DEMO_NAMES", "add_parser", "with_default_demo"]

DEMO_NAMES = ("pick-and-place", "mobile-robot", "bridge", "line", "datagen")
DEFAULT_DEMO = "pick-and-place"


def with_default_demo(argv: Iterable[str]) -> list[str]:
    """`argv` with the default demo's name after a bare `demo` (`simbridge demo --json` is
    `simbridge demo pick-and-place --json`); `simbridge demo --help` still lists the demos."""
    words = list(argv)
    i = 0
    while i < len(words) and words[i].startswith("-"):  # options before the command
        i += 2 if words[i] == "--log-level" else 1
    if i < len(words) and words[i] == "demo":
        after = words[i + 1 : i + 2]
        if not after or after[0] not in (*DEMO_NAMES, "-h", "--help"):
            words.insert(i + 1, DEFAULT_DEMO)
    return words


def _prepare(backend: str) -> None:
    """ROS 1 from Debian's packages, ROS 2 from its venv (a re-run there), before the demo
    imports either."""
    if backend == "ros1":
        ensure_ros1()
    elif backend == "ros2":
        reexec_in_ros2_venv()


def _run_pick_and_place(args: argparse.Namespace) -> int:
    _prepare(args.backend)
    from simbridge.apps.pick_and_place.runner import run_from_args

    return run_from_args(args)


def _run_mobile_robot(args: argparse.Namespace) -> int:
    _prepare(args.backend)
    from simbridge.apps.mobile_robot.runner import run_from_args

    return run_from_args(args)


def _run_line(args: argparse.Namespace) -> int:
    _prepare(args.backend)
    from simbridge.apps.line.runner import run_from_args

    return run_from_args(args)


def _run_bridge(args: argparse.Namespace) -> int:
    _prepare(args.backend)
    from simbridge.apps.bridge_demo import run_bridge_demo

    count = 5
    return 0 if run_bridge_demo(count, backend=args.backend, json=args.json) == count else 1


def _run_datagen(args: argparse.Namespace) -> int:
    from .datagen import run_demo

    return run_demo(args)


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    from simbridge.apps import options  # light: the demos themselves load when they run

    demo = sub.add_parser(
        "demo",
        help="run a demo end to end (embedded bus, ROS 1 or ROS 2)",
        description="Run a demo end to end; `simbridge demo` alone runs pick-and-place. "
        "`simbridge demo NAME --help` lists a demo's options.",
    )
    demos = demo.add_subparsers(dest="demo", metavar="NAME", required=True)
    p_pick = demos.add_parser(
        "pick-and-place",
        help="(default) a Niryo One arm picks a cube and places it, planned by a MoverService",
        description=options.PICK_AND_PLACE,
    )
    options.add_pick_and_place_arguments(p_pick)
    p_pick.set_defaults(func=_run_pick_and_place)
    p_mobile = demos.add_parser(
        "mobile-robot",
        help="a diff-drive robot with lidar, camera, IMU and odometry drives a square",
        description=options.MOBILE_ROBOT,
    )
    options.add_mobile_robot_arguments(p_mobile)
    p_mobile.set_defaults(func=_run_mobile_robot)
    p_line = demos.add_parser(
        "line",
        help="two arms and a conveyor, each in its own namespace, move parts through their "
        "controllers' actions",
        description=options.LINE,
    )
    options.add_line_arguments(p_line)
    p_line.set_defaults(func=_run_line)
    p_datagen = demos.add_parser(
        "datagen",
        help=f"a {options.DATAGEN_DEMO_FRAMES}-frame labelled COCO + BOP dataset of the "
        "pick-and-place table, with its contact sheet",
        description=options.DATAGEN,
    )
    options.add_datagen_arguments(
        p_datagen, frames=options.DATAGEN_DEMO_FRAMES, out="simbridge-datagen", workers=0
    )
    p_datagen.set_defaults(func=_run_datagen)
    p_bridge = demos.add_parser(
        "bridge",
        help="two connectors exchange Twist messages and a service call through an endpoint",
        description="Two connectors, a 'sim' and a 'ROS tool', exchange five Twist messages "
        "and a service call through an endpoint; no simulation.",
    )
    p_bridge.add_argument(
        "--backend",
        choices=["local", "ros1", "ros2"],
        default="local",
        help="local (default): the embedded bus, no ROS needed; ros1: real topics and "
        "services on the ROS 1 master at ROS_MASTER_URI, else a private roscore; ros2: real "
        "ROS 2 topics and services (localhost-only DDS, in the ROS 2 venv)",
    )
    p_bridge.add_argument(
        "--json",
        action="store_true",
        help='print a JSON summary last: {"success", "seed", "backend", "sim_s", "wall_s", '
        '"realtime_factor", "error", "sent", "received", "service_ok"}',
    )
    p_bridge.set_defaults(func=_run_bridge)
