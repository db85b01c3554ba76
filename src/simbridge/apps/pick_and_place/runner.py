"""Run the whole chain headless: endpoint, planner node, simulator; and its command line.

`main(argv)` is `simbridge demo pick-and-place [--backend local|ros1|ros2] [--json]
[--video PATH] [--seed N]`.
"""

from __future__ import annotations

import argparse
import dataclasses
import json as json_text
import sys
from collections.abc import Callable, Sequence
from contextlib import ExitStack
from pathlib import Path

from simbridge.apps.pick_and_place.planner_node import LocalPlannerNode
from simbridge.apps.pick_and_place.result import PickAndPlaceResult
from simbridge.apps.pick_and_place.ros1_graph import Ros1Graph
from simbridge.apps.pick_and_place.scene import SCENE_PATH, build_world
from simbridge.apps.pick_and_place.sim_side import ExecutionOptions, PickAndPlaceSim
from simbridge.apps.pick_and_place.task import PickAndPlaceTask
from simbridge.apps.pick_and_place.video import VideoRecorder, check_video_path
from simbridge.connector import Connector, ConnectorOptions
from simbridge.endpoint import EndpointOptions, EndpointThread, LocalBus, make_backend
from simbridge.endpoint.backends.ros1_master import unique_node_name
from simbridge.errors import AppError, SimbridgeError
from simbridge.sim.ros.publishers import StatePublisher
from simbridge.sim.ros.session import description_params
from simbridge.sim.scene.model import RosSettings

__all__ = ["BACKENDS", "main", "run_pick_and_place"]

BACKENDS = ("local", "ros1", "ros2")


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
) -> PickAndPlaceResult:
    """Pick the cube and place it on the target, planned by a ROS service; measure the result.

    The task is ``task``, else drawn from ``seed``, else the default one. ``backend`` "local"
    runs the planner as an in-process node on the endpoint's bus; "ros1" runs it as a rospy
    node (starting a roscore when ROS_MASTER_URI does not answer) and bridges with the ROS 1
    backend; "ros2" (in the ROS 2 venv) runs it as an rclpy node and bridges with the ROS 2
    backend, the sim speaking ROS 2. ``video`` writes a .gif (or .mp4 with ffmpeg);
    ``json`` prints the summary as the last line. Planning failures end in a result with
    ``error`` set; setup failures (bad backend, no master, bad video path) raise AppError.
    """
    if backend not in BACKENDS:
        raise AppError(f"unknown backend {backend!r}; choose one of {', '.join(BACKENDS)}")
    if task is None:
        task = PickAndPlaceTask.random(seed) if seed is not None else PickAndPlaceTask()
    video_path = check_video_path(video) if video is not None else None
    say = progress or (lambda _text: None)
    world = build_world(task, scene)
    recorder = VideoRecorder(world, video_path) if video_path is not None else None
    with ExitStack() as stack:
        if backend == "local":
            bus = LocalBus()
            endpoint = stack.enter_context(EndpointThread(EndpointOptions(port=0), bus))
            stack.enter_context(LocalPlannerNode(bus, scene))
            say(f"[pick-and-place] endpoint on port {endpoint.port} (local bus), planner node up")
        elif backend == "ros2":
            from simbridge.apps.pick_and_place.ros2_planner import (  # noqa: PLC0415 - rclpy
                Ros2PlannerNode,
            )

            stack.enter_context(Ros2PlannerNode(scene))
            ros2 = make_backend("ros2", node_name="/simbridge_endpoint")
            endpoint = stack.enter_context(EndpointThread(EndpointOptions(port=0), ros2))
            say(f"[pick-and-place] endpoint on port {endpoint.port} (ros2 backend), planner up")
        else:
            graph = stack.enter_context(Ros1Graph(scene))
            say(f"[pick-and-place] ROS master {graph.master.describe()}, planner node up")
            ros1 = make_backend("ros1", node_name=unique_node_name("simbridge_endpoint"))
            endpoint = stack.enter_context(EndpointThread(EndpointOptions(port=0), ros1))
            say(f"[pick-and-place] endpoint on port {endpoint.port} (ros1 backend)")
        connector = Connector("127.0.0.1", endpoint.port, ConnectorOptions(reconnect_initial=0.2))
        stack.enter_context(connector.connect())
        # What RViz shows (`simbridge rviz pick-and-place`): the arm's model, joints and TF.
        for name, description in description_params(world).items():
            connector.set_param(name, description)
        state = StatePublisher(world, connector, RosSettings(clock=False))
        state.start()
        stack.callback(state.close)
        sim = PickAndPlaceSim(
            world, connector, task, backend=backend, seed=seed, options=options, progress=say,
            recorder=recorder,
        )  # fmt: skip
        result = sim.run()
    if recorder is not None:
        result = dataclasses.replace(result, video=str(recorder.save()))
        say(f"[pick-and-place] wrote {result.video} ({recorder.frame_count} frames)")
    verdict = "success" if result.success else "FAILED"
    say(
        f"[pick-and-place] {verdict}: cube {result.cube_error_m * 100:.2f} cm from the target, "
        f"tilted {result.tilt_deg:.1f} deg; {result.sim_time:.2f} s simulated in "
        f"{result.wall_time:.2f} s"
    )
    if json:
        print(json_text.dumps(result.to_dict()), flush=True)
    return result


def main(argv: Sequence[str] | None = None) -> int:
    """`simbridge demo pick-and-place`: 0 on success, 1 when the cube missed, 2 on errors."""
    parser = argparse.ArgumentParser(
        prog="simbridge demo pick-and-place",
        description="Pick a cube and place it on a target with a Niryo One arm planned over ROS.",
    )
    parser.add_argument("--backend", choices=BACKENDS, default="local")
    parser.add_argument("--json", action="store_true", help="print a JSON summary last")
    parser.add_argument("--video", metavar="PATH", help="write a .gif (or .mp4 with ffmpeg)")
    parser.add_argument("--seed", type=int, help="draw a random cube and target from this seed")
    args = parser.parse_args(argv)
    try:
        result = run_pick_and_place(args.backend, args.seed, args.video, args.json)
    except SimbridgeError as exc:
        print(f"simbridge demo pick-and-place: {exc}", file=sys.stderr)
        return 2
    return 0 if result.success else 1
