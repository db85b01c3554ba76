"""Run the whole chain headless: endpoint, planner node, simulator; and its command line.

`main(argv)` is `simbridge demo pick-and-place [--backend local|ros1|ros2] [--json]
[--video PATH] [--seed N] [--realtime F] [--record FILE] [--view [--view-port P]]`.
"""

from __future__ import annotations

import argparse
import json as json_text
import sys
import threading
from collections.abc import Callable, Sequence
from pathlib import Path

from simbridge.apps.options import PICK_AND_PLACE, add_pick_and_place_arguments
from simbridge.apps.pick_and_place.demo import BACKENDS, PickAndPlaceDemo
from simbridge.apps.pick_and_place.result import PickAndPlaceResult
from simbridge.apps.pick_and_place.scene import SCENE_PATH
from simbridge.apps.pick_and_place.sim_side import ExecutionOptions
from simbridge.apps.pick_and_place.task import PickAndPlaceTask
from simbridge.apps.pick_and_place.video import check_video_path
from simbridge.errors import SimbridgeError
from simbridge.sim.record import RecordOptions
from simbridge.sim.view import ViewOptions

__all__ = ["BACKENDS", "main", "run_pick_and_place"]


def run_pick_and_place(
    backend: str = "local",
    seed: int | None = None,
    video: str | Path | None = None,
    json: bool = False,
    *,
    task: PickAndPlaceTask | None = None,
    scene: Path = SCENE_PATH,
    options: ExecutionOptions | None = None,
    progress: Callable[[str], None] | None = print,
    record: RecordOptions | None = None,
    view: ViewOptions | None = None,
    serve: threading.Event | None = None,
) -> PickAndPlaceResult:
    """Pick the cube and place it on the target, planned by a ROS service; measure the result.

    The task is ``task``, else drawn from ``seed``, else the default one. ``backend`` "local"
    runs the planner as an in-process node on the endpoint's bus; "ros1" runs it as a rospy
    node (starting a roscore when ROS_MASTER_URI does not answer) and bridges with the ROS 1
    backend; "ros2" (in the ROS 2 venv) runs it as an rclpy node and bridges with the ROS 2
    backend, the sim speaking ROS 2. ``video`` writes a .gif (or .mp4 with ffmpeg);
    ``json`` prints the summary as the last line; ``record`` writes every message the sim
    sends and receives to a bag. ``view`` serves the live browser view and then keeps
    serving, running again with a new seed at each press of the page's button, until
    Ctrl-C or until ``serve`` (an event) is set. Planning failures end in a result with
    ``error`` set; setup failures (bad backend, no master, bad video path) raise AppError.
    Returns the first run's result.
    """
    if task is None:
        task = PickAndPlaceTask.random(seed) if seed is not None else PickAndPlaceTask()
    video_path = check_video_path(video) if video is not None else None
    demo = PickAndPlaceDemo(
        backend, scene=scene, options=options, progress=progress, record=record, view=view
    )
    with demo:
        result = demo.run(task, seed, video_path)
        if json:
            print(json_text.dumps(result.to_dict()), flush=True)
        if view is not None:
            demo.serve(serve)
    return result


def main(argv: Sequence[str] | None = None) -> int:
    """`simbridge demo pick-and-place`: 0 on success, 1 when the cube missed, 2 on errors."""
    parser = argparse.ArgumentParser(
        prog="simbridge demo pick-and-place", description=PICK_AND_PLACE
    )
    add_pick_and_place_arguments(parser)
    return run_from_args(parser.parse_args(argv))


def run_from_args(args: argparse.Namespace) -> int:
    """Run the demo with parsed options: 0 on success, 1 when the cube missed, 2 on errors."""
    realtime = args.realtime if args.realtime is not None else (1.0 if args.view else 0.0)
    if not realtime >= 0:
        print("simbridge demo pick-and-place: --realtime must be >= 0", file=sys.stderr)
        return 2
    try:
        result = run_pick_and_place(
            args.backend,
            args.seed,
            args.video,
            args.json,
            options=ExecutionOptions(realtime_factor=realtime),
            record=RecordOptions(Path(args.record)) if args.record else None,
            view=ViewOptions(port=args.view_port) if args.view else None,
        )
    except SimbridgeError as exc:
        print(f"simbridge demo pick-and-place: {exc}", file=sys.stderr)
        return 2
    return 0 if result.success else 1
