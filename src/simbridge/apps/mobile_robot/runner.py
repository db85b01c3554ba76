"""Run the mobile-robot demo headless: endpoint, simulation with sensors, driver node.

`main(argv)` is `simbridge demo mobile-robot [--side M] [--realtime F] [--backend B] [--json]`.
"""

from __future__ import annotations

import argparse
import json as json_text
import math
import queue
import sys
import threading
import time
from collections.abc import Callable, Sequence
from contextlib import ExitStack, suppress
from pathlib import Path

from simbridge.apps.idle import next_request
from simbridge.apps.mobile_robot.driver import DriverNode, DriverTopics, SensorTally, SquarePath
from simbridge.apps.mobile_robot.result import MobileRobotResult
from simbridge.apps.options import (
    MOBILE_ROBOT,
    MOBILE_ROBOT_BACKENDS,
    add_mobile_robot_arguments,
)
from simbridge.apps.ros_master import DemoMaster
from simbridge.connector import ConnectorOptions
from simbridge.endpoint import Backend, EndpointOptions, EndpointThread, LocalBus, make_backend
from simbridge.endpoint.backends.ros1 import unique_node_name
from simbridge.errors import AppError, SimbridgeError
from simbridge.sim.control import Pose2D
from simbridge.sim.record import RecordOptions
from simbridge.sim.runner import SimulationSession
from simbridge.sim.urdf.transforms import Matrix, Transform
from simbridge.sim.view import LiveView, ViewOptions
from simbridge.sim.world import World

__all__ = ["BACKENDS", "BASE_LINK", "SCENE_PATH", "main", "run_mobile_robot"]

BACKENDS = MOBILE_ROBOT_BACKENDS

SCENE_PATH = Path(__file__).resolve().parent / "scene.yaml"
BASE_LINK = "base_link"
SETTLE_S = 0.5
"""Simulated seconds the robot stands still after the path before it is measured."""


def _yaw(rotation: Matrix) -> float:
    return math.atan2(float(rotation[1, 0]), float(rotation[0, 0]))


def _planar(pose: Transform, anchor: Transform) -> Pose2D:
    """`pose` in the levelled frame of `anchor` (what odometry calls odom)."""
    yaw0 = _yaw(anchor.rotation)
    dx, dy = (float(v) for v in (pose.translation - anchor.translation)[:2])
    c, s = math.cos(yaw0), math.sin(yaw0)
    yaw = math.remainder(_yaw(pose.rotation) - yaw0, math.tau)
    return Pose2D(c * dx + s * dy, -s * dx + c * dy, yaw)


def _errors(estimate: Pose2D | None, truth: Pose2D) -> tuple[float, float]:
    if estimate is None:
        return math.inf, math.inf
    distance = math.hypot(estimate.x - truth.x, estimate.y - truth.y)
    return distance, math.degrees(abs(math.remainder(estimate.yaw - truth.yaw, math.tau)))


def _wait(predicate: Callable[[], bool], timeout: float) -> bool:
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.005)
    return True


def _caught_up(world: World, driver: DriverNode) -> bool:
    """Whether the last odometry and joint states the driver got are the newest published."""
    tally = driver.tally()
    newest = world.time - 1.0 / 50 - 1e-6
    return tally.odom_stamp >= newest and tally.joint_states_stamp >= newest


def run_mobile_robot(
    side_m: float = 1.0,
    realtime_factor: float = 0.0,
    json: bool = False,
    *,
    scene: Path = SCENE_PATH,
    path: SquarePath | None = None,
    subscribe_sensors: bool = True,
    max_sim_s: float = 120.0,
    backend: str = "local",
    progress: Callable[[str], None] | None = print,
    record: RecordOptions | None = None,
    view: ViewOptions | None = None,
    serve: threading.Event | None = None,
) -> MobileRobotResult:
    """Drive diffbot around a square of `side_m` metres in the walled room and measure.

    Runs an endpoint, the scene's simulation (sensors, /cmd_vel diff drive) and a driver
    node closing the loop on /odom. `backend` "local" puts the endpoint and the driver on
    the embedded bus; "ros1" makes the endpoint a rospy node (on the master at
    ROS_MASTER_URI, else a private roscore) and the driver's topics real ROS topics, so
    `rostopic echo /odom` sees the run; "ros2" makes the endpoint an rclpy node (ROS 2
    venv; localhost-only DDS in ROS_DOMAIN_ID) and the driver's topics real ROS 2
    topics, and the sim speaks ROS 2 (CDR, ROS 2 layouts). `realtime_factor` 0 runs as
    fast as possible; `subscribe_sensors` False leaves lidar, camera and IMU without
    subscribers (so they are never computed). `json` prints the summary as the last line.
    `record` writes a bag of every sim topic; `view` serves the live browser view, which
    stays up after the run (the world stepping in real time) until Ctrl-C or until `serve`
    (an event) is set.
    """
    if backend not in BACKENDS:
        raise AppError(f"unknown backend {backend!r}; choose one of {', '.join(BACKENDS)}")
    say = progress or (lambda _text: None)
    path = path or SquarePath(side_m=side_m)
    with ExitStack() as stack:
        graph: Backend
        if backend == "local":
            graph, where = LocalBus(), "local bus"
        elif backend == "ros2":
            graph = make_backend("ros2", node_name="/simbridge_mobile_robot")
            where = "ros2 backend"
        else:
            master = stack.enter_context(DemoMaster())
            graph = make_backend("ros1", node_name=unique_node_name("simbridge_mobile_robot"))
            where = f"ros1 backend, ROS master {master.describe()}"
        endpoint = stack.enter_context(EndpointThread(EndpointOptions(port=0), graph))
        session = SimulationSession(
            scene,
            f"127.0.0.1:{endpoint.port}",
            ConnectorOptions(reconnect_initial=0.2),
            connect_timeout=5.0,
            record=record,
        )
        stack.enter_context(session)
        world = session.world
        bridge, sensors = session.bridge, session.sensors
        if view is not None:
            live = stack.enter_context(LiveView(world, view))
            if sensors is not None:
                sensors.add_observer(live.watch_sensors(sensors.suite))
            say(f"[mobile-robot] live view at {live.url}")
        if bridge is None or bridge.diff_drive is None or sensors is None:
            raise AppError(f"scene {scene} needs ros.diff_drive and sensors (odometry at least)")
        config = bridge.diff_drive.config
        topics = DriverTopics(cmd_vel=config.topic)
        driver = stack.enter_context(
            DriverNode(
                graph,
                bridge.diff_drive.kinematics,
                (config.left_joint, config.right_joint),
                path,
                topics=topics,
                subscribe_sensors=subscribe_sensors,
                progress=say,
                loop=endpoint.loop,
            )
        )
        watched = [topics.odom] + ([topics.scan, topics.image] if subscribe_sensors else [])
        if not _wait(lambda: all(sensors.publisher(t).has_subscribers for t in watched), 5.0):
            raise AppError(f"the simulation never saw subscribers on {', '.join(watched)}")
        say(
            f"[mobile-robot] endpoint on port {endpoint.port} ({where}); driving a "
            f"{path.side_m:g} m square"
        )
        anchor = world.link_pose(BASE_LINK)
        driver.on_done = world.stop
        first = world.run(max_sim_s, realtime_factor)
        settle = world.run(SETTLE_S, realtime_factor)
        caught_up = _wait(lambda: _caught_up(world, driver), 5.0)
        error = None
        if not driver.done.is_set():
            error = f"the square was not finished within {max_sim_s:g} s of sim time"
        elif not caught_up:
            error = "the last odometry or joint states never reached the driver"
        result = _result(
            driver.tally(),
            _planar(world.link_pose(BASE_LINK), anchor),
            sim_time=world.time,
            wall_time=first.wall_time + settle.wall_time,
            subscribed=subscribe_sensors,
            backend=backend,
            error=error,
        )
        _report(result, say, json)
        if view is not None:
            say(f"[mobile-robot] the view stays at {live.url} until Ctrl-C")
            with suppress(KeyboardInterrupt):  # the run is over: Ctrl-C ends the view only
                next_request(
                    queue.Queue(), serve or threading.Event(), world, realtime_factor, "view"
                )
    return result


def _report(result: MobileRobotResult, say: Callable[[str], None], json: bool) -> None:
    """The one-line verdict, and the JSON summary as the last line if asked."""
    verdict = "done" if result.success else f"FAILED ({result.error})"
    say(
        f"[mobile-robot] {verdict}: odom error {result.odom_error_m * 1000:.2f} mm, wheel "
        f"odometry error {result.wheel_odom_error_m * 100:.2f} cm / "
        f"{result.wheel_odom_yaw_error_deg:.2f} deg; nearest lidar return "
        f"{result.min_range_m:.3f} m; {result.scans_per_s:.1f} scans/s, "
        f"{result.images_per_s:.1f} images/s (sim); {result.sim_time:.1f} s simulated in "
        f"{result.wall_time:.1f} s (x{result.realtime_factor:.1f})"
    )
    if json:
        print(json_text.dumps(result.to_dict()), flush=True)


def _result(
    tally: SensorTally,
    truth: Pose2D,
    *,
    sim_time: float,
    wall_time: float,
    subscribed: bool,
    backend: str,
    error: str | None,
) -> MobileRobotResult:
    odom_m, odom_deg = _errors(tally.odom_pose, truth)
    wheel_m, wheel_deg = _errors(tally.wheel_pose, truth)
    per_s = 1.0 / sim_time if sim_time > 0 else 0.0
    return MobileRobotResult(
        success=error is None,
        sim_time=sim_time,
        wall_time=wall_time,
        final_pose=(truth.x, truth.y, truth.yaw),
        odom_error_m=odom_m,
        odom_yaw_error_deg=odom_deg,
        wheel_odom_error_m=wheel_m,
        wheel_odom_yaw_error_deg=wheel_deg,
        min_range_m=tally.min_range_m,
        scans_per_s=tally.scans * per_s,
        images_per_s=tally.images * per_s,
        imu_per_s=tally.imus * per_s,
        odom_per_s=tally.odoms * per_s,
        image_kib=tally.image_bytes / 1024 / tally.images if tally.images else 0.0,
        sensors_subscribed=subscribed,
        backend=backend,
        error=error,
        first_scan=tally.first_scan,
    )


def main(argv: Sequence[str] | None = None) -> int:
    """`simbridge demo mobile-robot`: 0 when the square was driven, 1 if not, 2 on errors."""
    parser = argparse.ArgumentParser(prog="simbridge demo mobile-robot", description=MOBILE_ROBOT)
    add_mobile_robot_arguments(parser)
    return run_from_args(parser.parse_args(argv))


def run_from_args(args: argparse.Namespace) -> int:
    """Run the demo with parsed options: 0 when the square was driven, 1 if not, 2 on
    errors."""
    if not 0.2 <= args.side <= 1.2:
        print("simbridge demo mobile-robot: --side must be in [0.2, 1.2] m", file=sys.stderr)
        return 2
    realtime = args.realtime if args.realtime is not None else (1.0 if args.view else 0.0)
    if not realtime >= 0:
        print("simbridge demo mobile-robot: --realtime must be >= 0", file=sys.stderr)
        return 2
    try:
        result = run_mobile_robot(
            args.side,
            realtime,
            args.json,
            backend=args.backend,
            record=RecordOptions(Path(args.record)) if args.record else None,
            view=ViewOptions(port=args.view_port) if args.view else None,
        )
    except SimbridgeError as exc:
        print(f"simbridge demo mobile-robot: {exc}", file=sys.stderr)
        return 2
    return 0 if result.success else 1
