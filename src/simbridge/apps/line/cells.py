"""The line's robot nodes: one per robot, each driving its robot only through its
controllers' standard actions (control_msgs/FollowJointTrajectory, GripperCommand) and
watching its `<ns>/joint_states`, as a ROS node on a real line would. The graph they use is
a `CellGraph`: an in-process node on the endpoint's bus (`NodeGraph`: local, ROS 1), or
rclpy in a process of its own (`ros2_cells.Ros2Graph`)."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from simbridge.endpoint import Backend, Node, NodeActionClient
from simbridge.errors import AppError
from simbridge.messages import MessageRegistry
from simbridge.messages.actionlib import SUCCEEDED
from simbridge.planning import JointTrajectory, robot_trajectory_message

__all__ = [
    "FOLLOW",
    "GRIPPER",
    "ArmCell",
    "CellGraph",
    "ConveyorCell",
    "GoalClient",
    "GoalHandle",
    "NodeGraph",
    "RobotNode",
    "RobotTally",
]

FOLLOW = "control_msgs/FollowJointTrajectory"
GRIPPER = "control_msgs/GripperCommand"
_STATUS_NAMES = (
    "PENDING", "ACTIVE", "PREEMPTED", "SUCCEEDED", "ABORTED",
    "REJECTED", "PREEMPTING", "RECALLING", "RECALLED", "LOST",
)  # fmt: skip
"""actionlib_msgs/GoalStatus values by number."""


class GoalHandle(Protocol):
    """A goal sent by a `GoalClient`: actionlib's status values (SUCCEEDED is 3)."""

    status: int | None
    result: Any
    text: str

    def wait(self, timeout: float | None = None) -> bool:
        """Block until the goal ended; False on timeout."""
        ...

    def cancel(self) -> None:
        """Ask the server to cancel the goal."""


class GoalClient(Protocol):
    """An action client (`NodeActionClient`'s face)."""

    @property
    def name(self) -> str:
        """The action's name."""
        ...

    def wait_for_server(self, timeout: float | None = None) -> bool:
        """True once the server can take goals."""
        ...

    def send_goal(self, goal: Any, on_feedback: Callable[[Any], None] | None = None) -> Any:
        """Send `goal` (a message of the graph's registry); a `GoalHandle`."""
        ...


class CellGraph(Protocol):
    """What a robot's node needs of the ROS graph."""

    @property
    def registry(self) -> MessageRegistry:
        """The layouts of the messages it builds and reads."""
        ...

    def action_client(self, name: str, action_type: str) -> GoalClient:
        """A client of action `name` (`pkg/Action`)."""
        ...

    def subscribe(self, topic: str, msg_type: str, callback: Callable[[Any], None]) -> None:
        """Call `callback(msg)` for every message on `topic`."""

    def close(self) -> None:
        """Leave the graph."""


class NodeGraph:
    """A `CellGraph` that is an in-process node on the endpoint's bus (local or ROS 1)."""

    def __init__(self, bus: Backend, name: str, *, loop: Any = None) -> None:
        self.node = Node(bus, name, loop=loop)

    @property
    def registry(self) -> MessageRegistry:
        """The node's registry."""
        return self.node.registry

    def action_client(self, name: str, action_type: str) -> GoalClient:
        """actionlib over the bus's topics."""
        return NodeActionClient(self.node, name, action_type)

    def subscribe(self, topic: str, msg_type: str, callback: Callable[[Any], None]) -> None:
        """A subscription of the node."""
        self.node.subscribe(topic, msg_type, callback)

    def close(self) -> None:
        """Withdraw the node's topics."""
        self.node.close()


@dataclass(frozen=True)
class RobotTally:
    """What one robot's node sent and heard during a run."""

    namespace: str
    goals: int
    feedback: int
    joint_states: int

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form."""
        return {
            "namespace": self.namespace,
            "goals": self.goals,
            "feedback": self.feedback,
            "joint_states": self.joint_states,
        }


class RobotNode:
    """A node for the robot in ``namespace`` on ``graph``: its joint states and action goals."""

    def __init__(
        self,
        graph: CellGraph,
        namespace: str,
        joints: tuple[str, ...],
        *,
        goal_timeout_s: float = 60.0,
        alive: Callable[[], bool] = lambda: True,
    ) -> None:
        self.namespace = namespace
        self.alive = alive
        """Whether the simulation still runs: waiting on a goal ends when it stops."""
        self.joints = joints
        self.goal_timeout_s = goal_timeout_s
        self.graph = graph
        self.registry = graph.registry
        self._lock = threading.Lock()
        self._positions: dict[str, float] = {}
        self._joint_states = 0
        self._feedback = 0
        self._goals = 0
        self._heard = threading.Event()
        self.trajectory = graph.action_client(self._controller_action(), FOLLOW)
        graph.subscribe(f"{namespace}/joint_states", "sensor_msgs/JointState", self._on_joints)

    def _controller_action(self) -> str:
        raise NotImplementedError

    def _on_joints(self, msg: Any) -> None:
        with self._lock:
            self._positions.update(zip(msg.name, (float(p) for p in msg.position), strict=False))
            self._joint_states += 1
        if all(j in self._positions for j in self.joints):
            self._heard.set()

    def _count_feedback(self, _msg: Any) -> None:
        with self._lock:
            self._feedback += 1

    def clients(self) -> list[GoalClient]:
        """Every action client of the node."""
        return [self.trajectory]

    def wait_ready(self, timeout: float) -> None:
        """Wait for joint states and every action server; AppError naming what is missing."""
        if not self._heard.wait(timeout):
            raise AppError(f"no {self.namespace}/joint_states within {timeout:g} s")
        for client in self.clients():
            if not client.wait_for_server(timeout):
                raise AppError(f"action server {client.name} did not come up in {timeout:g} s")

    def positions(self) -> np.ndarray:
        """The latest positions of ``joints`` from `<ns>/joint_states`."""
        with self._lock:
            return np.array([self._positions[j] for j in self.joints], dtype=np.float64)

    def _await(self, client: GoalClient, goal: Any, what: str) -> Any:
        with self._lock:
            self._goals += 1
        handle = client.send_goal(goal, on_feedback=self._count_feedback)
        deadline = time.monotonic() + self.goal_timeout_s
        while not handle.wait(0.05):
            if not self.alive():
                raise AppError(f"{client.name}: the simulation stopped during {what}")
            if time.monotonic() > deadline:
                handle.cancel()
                raise AppError(f"{client.name}: {what} got no result in {self.goal_timeout_s:g} s")
        if handle.status != SUCCEEDED:
            number = handle.status if handle.status is not None else -1
            status = _STATUS_NAMES[number] if 0 <= number < len(_STATUS_NAMES) else str(number)
            code = getattr(handle.result, "error_code", "")
            raise AppError(
                f"{client.name}: {what} ended {status} {code} {handle.text!r}".replace("  ", " ")
            )
        return handle.result

    def follow(self, trajectory: JointTrajectory, what: str) -> None:
        """Send ``trajectory`` as a FollowJointTrajectory goal and wait for success."""
        goal = self.registry.new(f"{FOLLOW}Goal")
        goal.trajectory = robot_trajectory_message(trajectory, self.registry).joint_trajectory
        result = self._await(self.trajectory, goal, what)
        if result.error_code != 0:
            raise AppError(f"{self.trajectory.name}: {what} failed, error_code {result.error_code}")

    def tally(self) -> RobotTally:
        """Counts so far."""
        with self._lock:
            return RobotTally(self.namespace, self._goals, self._feedback, self._joint_states)

    def close(self) -> None:
        """Leave the graph."""
        self.graph.close()


class ArmCell(RobotNode):
    """A Niryo One's node: arm_controller and gripper_controller of `<ns>`."""

    ARM_JOINTS = tuple(f"joint_{i}" for i in range(1, 7))
    GRIPPER_OPEN = 0.035
    GRIPPER_CLOSED = 0.002
    GRIP_EFFORT = 10.0
    HOLDING_MIN = 0.015
    """A closed gripper whose finger stopped above this (m) is holding a part."""

    def __init__(
        self, graph: CellGraph, namespace: str, *, alive: Callable[[], bool] = lambda: True
    ) -> None:
        super().__init__(graph, namespace, self.ARM_JOINTS, alive=alive)
        self.gripper = graph.action_client(f"{namespace}/gripper_controller/gripper_cmd", GRIPPER)

    def _controller_action(self) -> str:
        return f"{self.namespace}/arm_controller/follow_joint_trajectory"

    def clients(self) -> list[GoalClient]:
        """The arm's and the gripper's action clients."""
        return [self.trajectory, self.gripper]

    def grip(self, close: bool) -> float:
        """Close (on a part) or open the gripper; the finger position it ended at (m)."""
        goal = self.registry.new(f"{GRIPPER}Goal")
        goal.command.position = self.GRIPPER_CLOSED if close else self.GRIPPER_OPEN
        goal.command.max_effort = self.GRIP_EFFORT
        result = self._await(self.gripper, goal, "close" if close else "open")
        position = float(result.position)
        if close and position < self.HOLDING_MIN:
            raise AppError(
                f"{self.gripper.name}: the gripper closed to {position * 1000:.1f} mm: "
                "no part between the fingers"
            )
        return position


class ConveyorCell(RobotNode):
    """The conveyor's node: pallet_controller of `<ns>` moves the pallet."""

    def __init__(
        self,
        graph: CellGraph,
        namespace: str,
        *,
        alive: Callable[[], bool] = lambda: True,
        speed: float = 0.25,
    ) -> None:
        super().__init__(graph, namespace, ("pallet_joint",), alive=alive)
        self.speed = speed

    def _controller_action(self) -> str:
        return f"{self.namespace}/pallet_controller/follow_joint_trajectory"

    def move_to(self, target: float, what: str) -> None:
        """A smooth move (zero velocity at both ends) of the pallet to ``target`` (m)."""
        start = float(self.positions()[0])
        duration = max(0.5, 1.5 * abs(target - start) / self.speed)
        times = np.linspace(0.0, duration, 11)
        s = times / duration
        shape = 3 * s**2 - 2 * s**3
        rate = (6 * s - 6 * s**2) / duration
        accel = (6 - 12 * s) / duration**2
        distance = target - start
        trajectory = JointTrajectory(
            joint_names=self.joints,
            times=times,
            positions=(start + distance * shape)[:, None],
            velocities=(distance * rate)[:, None],
            accelerations=(distance * accel)[:, None],
        )
        self.follow(trajectory, what)
