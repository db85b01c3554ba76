"""The driver: an in-process node that drives a square over /cmd_vel and tallies the sensors.

It closes the loop on /odom (turn to face the next corner, drive to it, and at the end
turn back to the start heading), dead-reckons wheel odometry from /joint_states, and
counts what arrives on /scan, the camera's JPEG topic and /imu.
"""

from __future__ import annotations

import asyncio
import math
import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from simbridge.endpoint import Backend, Node
from simbridge.sim.control import DiffDriveKinematics, Pose2D

__all__ = ["DriverNode", "DriverTopics", "ScanSample", "SensorTally", "SquarePath"]


@dataclass(frozen=True)
class SquarePath:
    """A counter-clockwise square of `side` metres from the start pose, in the odom frame."""

    side_m: float = 1.0
    linear_speed: float = 0.3
    angular_speed: float = 1.0
    position_tolerance_m: float = 0.005
    heading_tolerance_rad: float = 0.01

    def corners(self) -> list[tuple[float, float]]:
        """The corners in driving order, ending back at the start."""
        s = self.side_m
        return [(s, 0.0), (s, s), (0.0, s), (0.0, 0.0)]


@dataclass(frozen=True)
class DriverTopics:
    """Where the driver listens and commands."""

    cmd_vel: str = "/cmd_vel"
    odom: str = "/odom"
    scan: str = "/scan"
    image: str = "/camera/image_raw/compressed"
    imu: str = "/imu"
    joint_states: str = "/joint_states"


@dataclass(frozen=True)
class ScanSample:
    """One LaserScan: sim time, first beam angle, angle step and the ranges (m)."""

    stamp: float
    angle_min: float
    angle_increment: float
    ranges: tuple[float, ...]

    def range_at(self, angle: float) -> float:
        """The range of the beam nearest `angle` (rad, in the scan frame)."""
        index = round(math.remainder(angle - self.angle_min, math.tau) / self.angle_increment)
        return self.ranges[index % len(self.ranges)]


@dataclass(frozen=True)
class SensorTally:
    """What the driver received: message counts, the nearest lidar return, the last odometry."""

    scans: int
    images: int
    image_bytes: int
    imus: int
    odoms: int
    min_range_m: float
    first_scan: ScanSample | None
    odom_pose: Pose2D | None
    odom_stamp: float
    wheel_pose: Pose2D
    joint_states_stamp: float


def _stamp(header: Any) -> float:
    return float(header.stamp.sec) + float(header.stamp.nanosec) * 1e-9


def _yaw(q: Any) -> float:
    return math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))


class DriverNode:
    """Drives `path` on `bus`; `done` is set (and `on_done` called) when it is back.

    `bus` is the LocalBus, or another started backend with the `loop` it runs on.
    """

    def __init__(
        self,
        bus: Backend,
        kinematics: DiffDriveKinematics,
        wheels: tuple[str, str],
        path: SquarePath | None = None,
        *,
        topics: DriverTopics | None = None,
        subscribe_sensors: bool = True,
        progress: Callable[[str], None] | None = None,
        loop: asyncio.AbstractEventLoop | None = None,
    ) -> None:
        self.kinematics, self.wheels = kinematics, wheels
        self.path = path or SquarePath()
        self.topics = topics or DriverTopics()
        self.progress = progress or (lambda _text: None)
        self.done = threading.Event()
        self.on_done: Callable[[], None] | None = None
        self._lock = threading.Lock()
        self._goals = self._plan()
        self._goal = 0
        self._counts = {"scans": 0, "images": 0, "image_bytes": 0, "imus": 0, "odoms": 0}
        self._min_range = math.inf
        self._first_scan: ScanSample | None = None
        self._odom: Pose2D | None = None
        self._odom_stamp = -math.inf
        self._wheel_pose = Pose2D()
        self._wheel_angles: tuple[float, float] | None = None
        self._joint_stamp = -math.inf
        self.node = Node(bus, "/mobile_robot_driver", loop=loop)
        self._cmd = self.node.advertise(self.topics.cmd_vel, "geometry_msgs/Twist")
        t = self.topics
        self.node.subscribe(t.odom, "nav_msgs/Odometry", self._on_odom)
        self.node.subscribe(t.joint_states, "sensor_msgs/JointState", self._on_joint_states)
        if subscribe_sensors:
            self.node.subscribe(t.scan, "sensor_msgs/LaserScan", self._on_scan)
            self.node.subscribe(t.image, "sensor_msgs/CompressedImage", self._on_image)
            self.node.subscribe(t.imu, "sensor_msgs/Imu", self._on_imu)

    def _plan(self) -> list[tuple[str, float, float, float]]:
        """(kind, x, y, yaw) goals: for every corner a turn to face it and a drive to it,
        then a final turn back to the start heading."""
        goals: list[tuple[str, float, float, float]] = []
        for x, y in self.path.corners():
            goals += [("face", x, y, 0.0), ("drive", x, y, 0.0)]
        goals.append(("heading", 0.0, 0.0, 0.0))
        return goals

    # --- control ---------------------------------------------------------------------------

    def _command(self, pose: Pose2D, stamp: float) -> tuple[float, float]:
        p = self.path
        while self._goal < len(self._goals):
            kind, gx, gy, gyaw = self._goals[self._goal]
            dx, dy = gx - pose.x, gy - pose.y
            if kind == "drive":
                leg_yaw = self._goals[self._goal - 1][3]  # set by the "face" goal before it
                along = dx * math.cos(leg_yaw) + dy * math.sin(leg_yaw)
                if along > p.position_tolerance_m:
                    heading = math.atan2(dy, dx)
                    steer = math.remainder(heading - pose.yaw, math.tau) if along > 0.05 else 0.0
                    linear = min(p.linear_speed, max(0.03, 1.5 * along))
                    return linear, max(-0.5, min(0.5, 2.0 * steer))
            else:
                target = math.atan2(dy, dx) if kind == "face" else gyaw
                error = math.remainder(target - pose.yaw, math.tau)
                if abs(error) > p.heading_tolerance_rad:
                    speed = max(0.05, min(p.angular_speed, 3.0 * abs(error)))
                    return 0.0, math.copysign(speed, error)
                if kind == "face":  # remember the leg direction for the drive that follows
                    self._goals[self._goal] = ("face", gx, gy, target)
            self._goal += 1
            if kind == "drive":
                corner = (self._goal + 1) // 2
                self.progress(
                    f"[mobile-robot] corner {corner}/{len(self.path.corners())} "
                    f"({gx:.2f}, {gy:.2f}) reached at t = {stamp:.2f} s"
                )
        if not self.done.is_set():
            self.done.set()
            if self.on_done is not None:
                self.on_done()
        return 0.0, 0.0

    # --- callbacks (the node's worker thread) ----------------------------------------------

    def _on_odom(self, msg: Any) -> None:
        pose = msg.pose.pose
        current = Pose2D(float(pose.position.x), float(pose.position.y), _yaw(pose.orientation))
        stamp = _stamp(msg.header)
        with self._lock:
            self._odom, self._odom_stamp = current, stamp
            self._counts["odoms"] += 1
        linear, angular = self._command(current, stamp)
        new = self.node.registry.new
        self._cmd.publish(
            new(
                "geometry_msgs/Twist",
                linear=new("geometry_msgs/Vector3", x=linear, y=0.0, z=0.0),
                angular=new("geometry_msgs/Vector3", x=0.0, y=0.0, z=angular),
            )
        )

    def _on_joint_states(self, msg: Any) -> None:
        names = list(msg.name)
        left = float(msg.position[names.index(self.wheels[0])])
        right = float(msg.position[names.index(self.wheels[1])])
        with self._lock:
            if self._wheel_angles is not None:
                dl, dr = left - self._wheel_angles[0], right - self._wheel_angles[1]
                self._wheel_pose = self.kinematics.integrate(self._wheel_pose, dl, dr)
            self._wheel_angles = (left, right)
            self._joint_stamp = _stamp(msg.header)

    def _on_scan(self, msg: Any) -> None:
        ranges = np.asarray(msg.ranges, dtype=np.float64)
        finite = ranges[np.isfinite(ranges)]
        with self._lock:
            self._counts["scans"] += 1
            if finite.size:
                self._min_range = min(self._min_range, float(finite.min()))
            if self._first_scan is None:
                self._first_scan = ScanSample(
                    _stamp(msg.header),
                    float(msg.angle_min),
                    float(msg.angle_increment),
                    tuple(float(r) for r in ranges),
                )

    def _on_image(self, msg: Any) -> None:
        if "jpeg" in str(msg.format) and len(msg.data) > 0:
            with self._lock:
                self._counts["images"] += 1
                self._counts["image_bytes"] += len(msg.data)

    def _on_imu(self, msg: Any) -> None:
        with self._lock:
            self._counts["imus"] += 1

    # --- results ---------------------------------------------------------------------------

    def tally(self) -> SensorTally:
        """A consistent snapshot of everything received so far."""
        with self._lock:
            c = self._counts
            return SensorTally(
                scans=c["scans"],
                images=c["images"],
                image_bytes=c["image_bytes"],
                imus=c["imus"],
                odoms=c["odoms"],
                min_range_m=self._min_range,
                first_scan=self._first_scan,
                odom_pose=self._odom,
                odom_stamp=self._odom_stamp,
                wheel_pose=self._wheel_pose,
                joint_states_stamp=self._joint_stamp,
            )

    def close(self) -> None:
        """Leave the bus."""
        self.node.close()

    def __enter__(self) -> DriverNode:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
