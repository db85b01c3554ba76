"""The simulation side: ask /niryo_moveit for a plan, execute it on the drives, grip by contact.

As the tutorial's TrajectoryPlanner does in Unity: send the arm's joints and the pick and
place poses, follow each returned trajectory by its time_from_start, close the gripper
after the grasp and open it after the place. The cube is only ever moved by contacts.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import numpy as np

from simbridge.apps.pick_and_place.conversion import pose_to_msg, sim_trajectory
from simbridge.apps.pick_and_place.planner_node import (
    LOG_ERROR,
    LOG_TOPIC,
    NODE_NAME,
    PLANNER_SERVICE,
    SERVICE_TYPE,
)
from simbridge.apps.pick_and_place.result import (
    SUCCESS_TOLERANCE_M,
    UPRIGHT_TOLERANCE_DEG,
    PhaseTiming,
    PickAndPlaceResult,
)
from simbridge.apps.pick_and_place.scene import CUBE
from simbridge.apps.pick_and_place.task import PickAndPlaceTask
from simbridge.apps.pick_and_place.video import VideoRecorder
from simbridge.connector import Connector
from simbridge.errors import AppError, SimbridgeError
from simbridge.messages import MessageRegistry
from simbridge.sim import World
from simbridge.sim.world.pacer import Pacer

__all__ = ["ARM_JOINTS", "GRIPPER_JOINT", "STAGES", "ExecutionOptions", "PickAndPlaceSim"]

ARM_JOINTS = tuple(f"joint_{i}" for i in range(1, 7))
GRIPPER_JOINT = "left_finger_joint"
STAGES = ("pre_grasp", "grasp", "pick_up", "place")
"""The four trajectories of a MoverService response, in order."""


@dataclass(frozen=True)
class ExecutionOptions:
    """Timings (simulated seconds) of the sim side, and how long to wait on the planner."""

    settle_s: float = 0.2
    """Let the cube come to rest on the table before planning."""
    trajectory_margin_s: float = 0.15
    """Keep following the last point this long after a trajectory ends."""
    grip_s: float = 0.5
    """Time given to the gripper to close or open."""
    final_settle_s: float = 0.5
    """Time for the released cube to come to rest before it is measured."""
    realtime_factor: float = 0.0
    """Pace the motion at this many sim seconds per wall second (0: as fast as possible;
    a live view wants 1)."""
    service_timeout_s: float = 30.0
    error_wait_s: float = 2.0
    """After an empty plan, how long to wait for the planner's reason on /rosout (wall)."""


_ROS2_LOG = ("rcl_interfaces/Log", 40)
"""/rosout in ROS 2: rcl_interfaces/msg/Log, whose ERROR level is 40."""


class _PlannerErrors:
    """Collects the planner node's ERROR messages from /rosout."""

    def __init__(self, error_level: int = LOG_ERROR) -> None:
        self.error_level = error_level
        self.messages: list[str] = []
        self._event = threading.Event()

    def __call__(self, msg: Any) -> None:
        if msg.level >= self.error_level and msg.name.lstrip("/") == NODE_NAME:
            self.messages.append(str(msg.msg))
            self._event.set()

    def wait(self, timeout: float) -> str | None:
        """The latest reason, waiting up to ``timeout`` seconds for one to arrive."""
        self._event.wait(timeout)
        return self.messages[-1] if self.messages else None


class PickAndPlaceSim:
    """Runs one pick and place of ``task`` in ``world`` through a connected ``connector``."""

    def __init__(
        self,
        world: World,
        connector: Connector,
        task: PickAndPlaceTask,
        *,
        backend: str = "local",
        seed: int | None = None,
        options: ExecutionOptions | None = None,
        recorder: VideoRecorder | None = None,
        progress: Callable[[str], None] | None = None,
        registry: MessageRegistry | None = None,
    ) -> None:
        self.world = world
        self.connector = connector
        self.task = task
        self.backend = backend
        self.seed = seed
        self.options = options or ExecutionOptions()
        self.recorder = recorder
        self.progress = progress or (lambda _text: None)
        self.registry = registry or connector.registry  # the endpoint's ROS 1 or ROS 2 layouts
        self.phases: list[PhaseTiming] = []
        self._track: list[tuple[float, float, float, float]] = []
        self._cube = world.model.body(CUBE).id
        log_type, error_level = (
            _ROS2_LOG if connector.protocol == "ROS2" else ("rosgraph_msgs/Log", LOG_ERROR)
        )
        self._errors = _PlannerErrors(error_level)
        self._gripper_closed_at: float | None = None
        gripper = world.model.joint(GRIPPER_JOINT)
        self._gripper_open, self._gripper_closed = float(gripper.range[1]), float(gripper.range[0])
        connector.register_ros_service(PLANNER_SERVICE, SERVICE_TYPE)
        connector.subscribe(LOG_TOPIC, log_type, self._errors)

    # --- stepping --------------------------------------------------------------------------

    def _advance(self, seconds: float) -> None:
        """Step the world ``seconds`` of sim time (paced, and held while paused), recording
        the cube and video frames."""
        world = self.world
        end = world.time + seconds - 1e-9
        pacer = Pacer(self.options.realtime_factor)
        pacer.restart(world.time)
        while world.time < end:
            if world.paused:  # the live view's pause and step N
                world.hold_while_paused()
                pacer.restart(world.time)
            world.step()
            pacer.wait(world.time)
            x, y, z = world.data.xpos[self._cube]
            self._track.append((world.time, float(x), float(y), float(z)))
            if self.recorder is not None:
                self.recorder.maybe_capture()

    @contextmanager
    def _phase(self, name: str) -> Iterator[None]:
        sim0, wall0 = self.world.time, time.perf_counter()
        yield
        timing = PhaseTiming(name, self.world.time - sim0, time.perf_counter() - wall0)
        self.phases.append(timing)
        self.progress(
            f"[pick-and-place] {name:<13} {timing.sim_s:6.2f} s sim  {timing.wall_s:7.3f} s wall"
        )

    def grasp_offset(self) -> float:
        """Distance (m) from the tool frame to the grasp point between the finger pads."""
        tool = self.world.link_pose("tool_link").translation
        grasp = self.world.link_pose("grasp_link").translation
        return float(np.linalg.norm(grasp - tool))

    # --- the run ----------------------------------------------------------------------------

    def request(self) -> Any:
        """The MoverService request for the arm's current joints and the task's poses."""
        joints = self.world.joint_positions(list(ARM_JOINTS))
        offset = self.grasp_offset()
        request = self.registry.new(self.registry.service(SERVICE_TYPE).request)
        request.joints_input.joints = np.array([joints[j] for j in ARM_JOINTS])
        request.pick_pose = pose_to_msg(self.registry, self.task.pick_pose(offset))
        request.place_pose = pose_to_msg(self.registry, self.task.place_pose(offset))
        return request

    def _plan(self) -> list[Any]:
        with self._phase("plan"):
            future = self.connector.call_service(
                PLANNER_SERVICE, self.request(), timeout=self.options.service_timeout_s
            )
            response = future.result()
        trajectories = list(response.trajectories)
        if len(trajectories) != len(STAGES):
            reason = self._errors.wait(self.options.error_wait_s)
            raise AppError(
                reason
                or f"the planner returned {len(trajectories)} trajectories (expected "
                f"{len(STAGES)}) and logged no reason"
            )
        return trajectories

    def _follow(self, name: str, message: Any) -> None:
        trajectory = sim_trajectory(message)
        with self._phase(name):
            self.world.follower.start(trajectory, self.world.time)
            self._advance(trajectory.duration + self.options.trajectory_margin_s)

    def _grip(self, name: str, position: float) -> None:
        with self._phase(name):
            self.world.drives.set_position(GRIPPER_JOINT, position)
            self._advance(self.options.grip_s)

    def run(self) -> PickAndPlaceResult:
        """Plan, execute and measure; failures end the run with ``error`` set, never raise."""
        error: str | None = None
        count = 0
        try:
            with self._phase("settle"):
                self._advance(self.options.settle_s)
            trajectories = self._plan()
            count = len(trajectories)
            self._follow("pre_grasp", trajectories[0])
            self._follow("grasp", trajectories[1])
            self._gripper_closed_at = self.world.time
            self._grip("close_gripper", self._gripper_closed)
            self._follow("pick_up", trajectories[2])
            self._follow("place", trajectories[3])
            self._grip("open_gripper", self._gripper_open)
            with self._phase("release"):
                self._advance(self.options.final_settle_s)
        except SimbridgeError as exc:
            error = str(exc)
            self.progress(f"[pick-and-place] failed: {error}")
        return self._result(error, count)

    def _result(self, error: str | None, count: int) -> PickAndPlaceResult:
        data = self.world.data
        final = tuple(float(v) for v in data.xpos[self._cube])
        target = self.task.target_center
        cube_error = math.dist(final, target)
        rotation = data.xmat[self._cube].reshape(3, 3)
        vertical = min(1.0, float(np.max(np.abs(rotation[2]))))
        tilt = math.degrees(math.acos(vertical))
        success = (
            error is None and cube_error <= SUCCESS_TOLERANCE_M and tilt <= UPRIGHT_TOLERANCE_DEG
        )
        if self.recorder is not None:
            self.recorder.maybe_capture()
        return PickAndPlaceResult(
            success=success,
            cube_error_m=cube_error,
            tilt_deg=tilt,
            phases=tuple(self.phases),
            backend=self.backend,
            seed=self.seed,
            cube_start=self.task.cube_center,
            target=target,
            cube_final=(final[0], final[1], final[2]),
            error=error,
            gripper_closed_at=self._gripper_closed_at,
            trajectories=count,
            cube_track=np.array(self._track, dtype=np.float64).reshape(-1, 4),
        )
