"""The demos' command-line options, apart from the demos so `simbridge --help` and
`simbridge demo NAME --help` need none of their heavy imports (MuJoCo, the endpoint)."""

from __future__ import annotations

import argparse
import os

__all__ = [
    "DATAGEN",
    "DATAGEN_DEMO_FRAMES",
    "LINE",
    "LINE_BACKENDS",
    "LINE_MAX_PARTS",
    "MOBILE_ROBOT",
    "MOBILE_ROBOT_BACKENDS",
    "PICK_AND_PLACE",
    "PICK_AND_PLACE_BACKENDS",
    "add_datagen_arguments",
    "add_line_arguments",
    "add_mobile_robot_arguments",
    "add_pick_and_place_arguments",
]

PICK_AND_PLACE_BACKENDS = ("local", "ros1", "ros2")
MOBILE_ROBOT_BACKENDS = ("local", "ros1", "ros2")
LINE_BACKENDS = ("local", "ros1", "ros2")
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

DATAGEN = (
    "Write a labelled, randomised image dataset of the pick-and-place table (cubes, a can, "
    "clutter, lights, colours, camera and arm pose drawn per frame): COCO and BOP beside the "
    "native layout, and a contact sheet to look at first."
)
"""What the datagen demo does (its --help description)."""
DATAGEN_DEMO_FRAMES = 200
"""Frames `simbridge demo datagen` writes."""


def add_pick_and_place_arguments(parser: argparse.ArgumentParser) -> None:
    """The demo's options (`simbridge demo pick-and-place --help`)."""
    _add_shared_arguments(
        parser,
        backends=PICK_AND_PLACE_BACKENDS,
        backend_help=(
            "local (default): the embedded bus, no ROS needed; ros1: real topics and "
            "services on the ROS 1 master at ROS_MASTER_URI, else a private roscore; ros2: real "
            "ROS 2 topics and services (localhost-only DDS, in the ROS 2 venv)"
        ),
        summary='"cube_error_m", "phases"',
        view_help=(
            "live browser view (viser); keeps serving after the run, with a button that "
            "runs again with a new seed, until Ctrl-C"
        ),
    )
    parser.add_argument(
        "--seed",
        type=int,
        help="draw a random cube and target from this seed (default: the fixed task, "
        '"seed": null in the JSON)',
    )


def add_mobile_robot_arguments(parser: argparse.ArgumentParser) -> None:
    """The demo's options (`simbridge demo mobile-robot --help`)."""
    _add_shared_arguments(
        parser,
        backends=MOBILE_ROBOT_BACKENDS,
        backend_help=(
            "local (default): the embedded bus, no ROS needed; ros1: real ROS topics on the "
            "ROS 1 master at ROS_MASTER_URI, else a private roscore; ros2: real ROS 2 topics "
            "(localhost-only DDS, in the ROS 2 venv)"
        ),
        summary='"odom_error_m"',
        view_help=(
            "live browser view (viser), in real time unless --realtime says otherwise; "
            "stays up after the run until Ctrl-C"
        ),
        video=False,
    )
    parser.add_argument(
        "--side", type=float, default=1.0, help="square side in metres, 0.2 to 1.2 (default 1)"
    )


def add_line_arguments(parser: argparse.ArgumentParser) -> None:
    """The demo's options (`simbridge demo line --help`)."""
    _add_shared_arguments(
        parser,
        backends=LINE_BACKENDS,
        backend_help=(
            "local (default): the embedded bus; ros1: real ROS 1 topics and actions on the "
            "master at ROS_MASTER_URI (else a private roscore); ros2: real ROS 2 topics and "
            "actions (localhost-only DDS, in the ROS 2 venv), the robots driven from a separate "
            "rclpy process"
        ),
        summary='"parts", "delivered"',
        view_help=(
            "live browser view (viser); keeps serving after the run, with a button that "
            "runs the line again with the next seed (Ctrl-C ends)"
        ),
    )
    parser.add_argument(
        "--seed", type=int, default=0, help="draw the part poses from this seed (default 0)"
    )
    parser.add_argument(
        "--parts", type=int, default=3, help=f"parts to move, 1 to {LINE_MAX_PARTS} (default 3)"
    )


def _add_shared_arguments(
    parser: argparse.ArgumentParser,
    *,
    backends: tuple[str, ...],
    backend_help: str,
    summary: str,
    view_help: str,
    video: bool = True,
) -> None:
    """The options every demo has, worded for it where they differ: --backend, --json
    (`summary`: its own keys after the shared ones), --video (where the demo films),
    --realtime, --record, --view and --view-port."""
    parser.add_argument("--backend", choices=backends, default="local", help=backend_help)
    parser.add_argument(
        "--json",
        action="store_true",
        help='print a JSON summary last: {"success", "seed", "backend", "sim_s", "wall_s", '
        f'"realtime_factor", "error", {summary}, ...}}',
    )
    if video:
        parser.add_argument("--video", metavar="PATH", help="write a .gif (or .mp4 with ffmpeg)")
    parser.add_argument(
        "--realtime",
        type=float,
        help="sim seconds per wall second (default: 1 with --view, else 0 = as fast as possible)",
    )
    parser.add_argument("--record", metavar="FILE", help="record the run (.mcap or .bag)")
    parser.add_argument("--view", action="store_true", help=view_help)
    parser.add_argument(
        "--view-port", type=int, default=8080, help="live view port (default 8080; 0: any free)"
    )


def _workers(text: str) -> int:
    value = int(text) if text.isdigit() else -1
    if value < 0:
        raise argparse.ArgumentTypeError(f"--workers {text!r}: expected a whole number >= 0")
    return value or (os.cpu_count() or 1)


def add_datagen_arguments(
    parser: argparse.ArgumentParser,
    *,
    frames: int | None,
    out: str | None = None,
    workers: int = 1,
) -> None:
    """Options of `simbridge datagen` (`frames`/`out` None: required) and of `simbridge
    demo datagen` (their defaults given; `workers` 0: one per CPU)."""
    parser.add_argument(
        "--frames",
        type=int,
        default=frames,
        required=frames is None,
        help="frames to make, 0 .. N-1" + (f" (default {frames})" if frames else ""),
    )
    parser.add_argument(
        "--out",
        default=out,
        required=out is None,
        help="the dataset folder" + (f" (default {out})" if out else ""),
    )
    parser.add_argument(
        "--format",
        default="coco,bop",
        help="comma-separated: coco, bop, native (the native layout is always written; "
        "default coco,bop)",
    )
    parser.add_argument(
        "--seed", type=int, default=0, help="dataset seed: same seed, same bytes (default 0)"
    )
    parser.add_argument(
        "--quality",
        choices=("fast", "balanced", "high"),  # perception.render.QUALITIES (not imported)
        help="render preset over the scene's `render:` settings: fast (no shadows, no "
        "anti-aliasing; about 5x faster on a CPU than high), balanced (shadows from a 2048 "
        "map, no anti-aliasing; about 2x) or high (shadows, 4x multisampling); labels are "
        "the same (default: the scene's)",
    )
    parser.add_argument(
        "--resume",
        action="store_true",
        help="continue the dataset in --out at its first missing frame (same scene, seed, "
        "formats and render settings)",
    )
    parser.add_argument(
        "--workers",
        type=_workers,
        default=workers or (os.cpu_count() or 1),
        help="processes rendering frames (0: one per CPU; default "
        + (str(workers) if workers else "one per CPU")
        + "); the files are the same",
    )
