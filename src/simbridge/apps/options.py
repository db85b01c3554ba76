"""The demos' command-line options, apart from the demos so `simbridge --help` and
`simbridge demo NAME --help` need none of their heavy imports (MuJoCo, the endpoint)."""

from __future__ import annotations

import argparse

__all__ = [
    "LINE",
    "LINE_BACKENDS",
    "LINE_MAX_PARTS",
    "MOBILE_ROBOT",
    "MOBILE_ROBOT_BACKENDS",
    "PICK_AND_PLACE",
    "PICK_AND_PLACE_BACKENDS",
    "add_line_arguments",
    "add_mobile_robot_arguments",
    "add_pick_and_place_arguments",
]

PICK_AND_PLACE_BACKENDS = ("local", "ros1", "ros2")
MOBILE_ROBOT_BACKENDS = ("local", "ros1", "ros2")
LINE_BACKENDS = ("local", "ros1")  # the controllers speak ROS 1 actions
LINE_MAX_PARTS = 4
"""The line's output slots (`simbridge.apps.line.task.MAX_PARTS`, checked by a test)."""

PICK_AND_PLACE = "Pick a cube and place it on a target with a Niryo One arm planned over ROS."
"""What the pick-and-place demo does (its --help description)."""

MOBILE_ROBOT = (
    "Drive a differential-drive robot around a square in a walled room over ROS topics "
    "(/cmd_vel, /odom, /scan, camera, /imu) and measure what arrives."
)
"""What the mobile-robot demo does (its --help description)."""

LINE = (
    "A small production line: two Niryo One arms and a conveyor, each in its own namespace, "
    "move parts from an input area to an output area through their controllers' actions."
)
"""What the line demo does (its --help description)."""


def add_pick_and_place_arguments(parser: argparse.ArgumentParser) -> None:
    """The demo's options (`simbridge demo pick-and-place --help`)."""
    parser.add_argument(
        "--backend",
        choices=PICK_AND_PLACE_BACKENDS,
        default="local",
        help="local (default): the embedded bus, no ROS needed; ros1: real topics and "
        "services on the ROS 1 master at ROS_MASTER_URI, else a private roscore; ros2: real "
        "ROS 2 topics and services (localhost-only DDS, in the ROS 2 venv)",
    )
    parser.add_argument(
        "--json",
        action="store_true",
        help='print a JSON summary last: {"success", "seed", "backend", "sim_s", "wall_s", '
        '"realtime_factor", "error", "cube_error_m", "phases", ...}',
    )
    parser.add_argument("--video", metavar="PATH", help="write a .gif (or .mp4 with ffmpeg)")
    parser.add_argument(
        "--seed",
        type=int,
        help="draw a random cube and target from this seed (default: the fixed task, "
        '"seed": null in the JSON)',
    )
    parser.add_argument(
        "--realtime",
        type=float,
        help="sim seconds per wall second (default: 1 with --view, else 0 = as fast as possible)",
    )
    parser.add_argument("--record", metavar="FILE", help="record the run (.mcap or .bag)")
    parser.add_argument(
        "--view",
        action="store_true",
        help="live browser view (viser); keeps serving after the run, with a button that "
        "runs again with a new seed, until Ctrl-C",
    )
    parser.add_argument(
        "--view-port", type=int, default=8080, help="live view port (default 8080; 0: any free)"
    )


def add_mobile_robot_arguments(parser: argparse.ArgumentParser) -> None:
    """The demo's options (`simbridge demo mobile-robot --help`)."""
    parser.add_argument(
        "--side", type=float, default=1.0, help="square side in metres, 0.2 to 1.2 (default 1)"
    )
    parser.add_argument(
        "--realtime",
        type=float,
        default=None,
        help="sim seconds per wall second (default: 1 with --view, else 0 = as fast as possible)",
    )
    parser.add_argument(
        "--backend",
        choices=MOBILE_ROBOT_BACKENDS,
        default="local",
        help="local (default): the embedded bus, no ROS needed; ros1: real ROS topics on the "
        "ROS 1 master at ROS_MASTER_URI, else a private roscore; ros2: real ROS 2 topics "
        "(localhost-only DDS, in the ROS 2 venv)",
    )
    parser.add_argument(
        "--json",
        action="store_true",
        help='print a JSON summary last: {"success", "seed", "backend", "sim_s", "wall_s", '
        '"realtime_factor", "error", "odom_error_m", ...}',
    )
    parser.add_argument("--record", metavar="FILE", help="record the run (.mcap or .bag)")
    parser.add_argument(
        "--view",
        action="store_true",
        help="live browser view (viser), in real time unless --realtime says otherwise; "
        "stays up after the run until Ctrl-C",
    )
    parser.add_argument(
        "--view-port", type=int, default=8080, help="live view port (default 8080; 0: any free)"
    )


def add_line_arguments(parser: argparse.ArgumentParser) -> None:
    """The demo's options (`simbridge demo line --help`)."""
    parser.add_argument(
        "--seed", type=int, default=0, help="draw the part poses from this seed (default 0)"
    )
    parser.add_argument(
        "--backend",
        choices=LINE_BACKENDS,
        default="local",
        help="local (default): the embedded bus; ros1: real ROS 1 topics and actions on the "
        "master at ROS_MASTER_URI (else a private roscore)",
    )
    parser.add_argument(
        "--parts", type=int, default=3, help=f"parts to move, 1 to {LINE_MAX_PARTS} (default 3)"
    )
    parser.add_argument(
        "--json",
        action="store_true",
        help='print a JSON summary last: {"success", "seed", "backend", "sim_s", "wall_s", '
        '"realtime_factor", "error", "parts", "delivered", ...}',
    )
    parser.add_argument("--video", metavar="PATH", help="write a .gif (or .mp4 with ffmpeg)")
    parser.add_argument(
        "--realtime",
        type=float,
        help="sim seconds per wall second (default: 1 with --view, else 0 = as fast as possible)",
    )
    parser.add_argument("--record", metavar="FILE", help="record the run (.mcap or .bag)")
    parser.add_argument(
        "--view",
        action="store_true",
        help="live browser view (viser); keeps serving after the run, with a button that "
        "runs the line again with the next seed (Ctrl-C ends)",
    )
    parser.add_argument(
        "--view-port", type=int, default=8080, help="live view port (default 8080; 0: any free)"
    )
