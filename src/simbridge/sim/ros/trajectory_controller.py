"""ros_control's joint_trajectory_controller for one robot: the
`<ns>/<name>/follow_joint_trajectory` action (control_msgs/FollowJointTrajectory), the
`<ns>/<name>/command` topic (trajectory_msgs/JointTrajectory) and `<ns>/<name>/state`
(control_msgs/JointTrajectoryControllerState), with the real controller's semantics:
path and goal tolerances, goal_time_tolerance, preemption by a new goal or command,
cancel (hold position), feedback at `action_monitor_rate`, result error codes. On ROS 2 the
messages have control_msgs 5.x (Jazzy) layouts: the state's reference/feedback/error/output,
empty multi-DOF fields; a goal with a multi-DOF trajectory is refused (INVALID_JOINTS: the
sim has no multi-DOF joints), so its component tolerances, which only address those, are
never used."""

from __future__ import annotations

import logging
from dataclasses import replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from simbridge.connector import (
    ActionServer,
    AnyServerGoal,
    Connector,
    Ros2ActionServer,
    action_server,
)
from simbridge.errors import SimError
from simbridge.sim.control.drive import DriveMode
from simbridge.sim.control.follower import TrajectoryFollower
from simbridge.sim.control.trajectory import Trajectory, Vector
from simbridge.sim.ros.convert import StampMaker, duration_seconds, trajectory_from_message
from simbridge.sim.ros.names import RobotNames, resolve_name
from simbridge.sim.scene.spec import TrajectoryControllerSpec
from simbridge.sim.world.callbacks import CallbackHandle
from simbridge.sim.world.world import World

__all__ = ["JointTrajectoryController"]

_log = logging.getLogger("simbridge.sim.ros")

ACTION = "control_msgs/FollowJointTrajectory"
SUCCESSFUL, INVALID_GOAL, INVALID_JOINTS = 0, -1, -2
PATH_TOLERANCE_VIOLATED, GOAL_TOLERANCE_VIOLATED = -4, -5


class JointTrajectoryController:
    """One joint_trajectory_controller; all its work runs on the simulation thread."""

    def __init__(
        self,
        world: World,
        connector: Connector,
        names: RobotNames,
        namespace: str,
        spec: TrajectoryControllerSpec,
    ) -> None:
        self.world, self.connector, self.names, self.spec = world, connector, names, spec
        self.joints = [names.world_joint(j) for j in spec.joints]
        """World names of the controller's joints, in the spec's order."""
        self.ros_joints = list(spec.joints)
        for joint in self.joints:
            world.drives.spec(joint)  # SimError for joints without drives
        for joint in spec.constraints:
            if joint not in spec.joints:
                raise SimError(
                    f"controller {spec.name!r}: constraint for {joint!r}, which is not one of "
                    f"its joints ({', '.join(spec.joints)})"
                )
        self.prefix = resolve_name(namespace, spec.name)
        self.follower = TrajectoryFollower(world.drives)
        self._trajectory: Trajectory | None = None
        self._start = 0.0
        self._goal: AnyServerGoal | None = None
        self._path_tol: dict[str, float] = {}
        self._goal_tol: dict[str, float] = {}
        self._goal_time = spec.goal_time
        # Per followed trajectory (its joints' order): qpos/qvel indices and the
        # tolerances as (trajectory index, tolerance) arrays, None when there are none.
        self._qpos: NDArray[np.intp] = np.zeros(0, np.intp)
        self._dofs: NDArray[np.intp] = np.zeros(0, np.intp)
        self._path_check: _Check | None = None
        self._in_controller: NDArray[np.intp] = np.zeros(0, np.intp)
        """Where the followed trajectory's joints sit among the controller's."""
        _names, self._all_qpos, self._all_dofs = world.joint_indices(self.joints)
        self._actuators = world.drives.actuators(self.joints)
        self._goal_check: _Check | None = None
        self._stamps = StampMaker(connector.registry)
        self._fields: dict[str, frozenset[str]] = {}
        """Field names of the state and feedback types (ROS 1 or ROS 2 layout), by type."""
        self._server: ActionServer | Ros2ActionServer | None = None
        self._callbacks: list[CallbackHandle] = []
        self.state_topic = f"{self.prefix}/state"
        self.command_topic = f"{self.prefix}/command"

    # ---- lifecycle ------------------------------------------------------------------------

    def start(self) -> JointTrajectoryController:
        """Register the action, command and state topics; follow before every step and
        check the goal after it."""
        world = self.world
        self.connector.register_publisher(
            self.state_topic, "control_msgs/JointTrajectoryControllerState", queue_size=10
        )
        self.connector.subscribe(
            self.command_topic,
            "trajectory_msgs/JointTrajectory",
            lambda msg: world.post(lambda: self._on_command(msg)),
        )
        self._server = action_server(
            self.connector,
            f"{self.prefix}/follow_joint_trajectory",
            ACTION,
            lambda goal: world.post(lambda: self._on_goal(goal)),
            lambda goal: world.post(lambda: self._on_cancel(goal)),
            clock=lambda: world.time,
        )
        self._callbacks = [
            world.add_follower(self.follower),
            world.add_step_callback(lambda _w: self._update()),
            world.add_step_callback(
                lambda _w: self._publish_feedback(), 1.0 / self.spec.action_monitor_rate
            ),
            world.add_step_callback(
                lambda _w: self._publish_state(), 1.0 / self.spec.state_publish_rate
            ),
            world.add_reset_callback(lambda _w: self._stop()),
        ]
        return self

    def close(self) -> None:
        """Unregister everything (the connector stays open); nothing of it runs on later
        steps or resets."""
        for callback in self._callbacks:
            callback.remove()
        self._callbacks.clear()
        if self._server is not None:
            self._server.close()
            self._server = None
            self.connector.unsubscribe(self.command_topic)
            self.connector.unregister_publisher(self.state_topic)

    # ---- commands -------------------------------------------------------------------------

    def _result(self, code: int, text: str = "") -> Any:
        return self.connector.registry.new(f"{ACTION}Result", error_code=code, error_string=text)

    def _trajectory_of(self, msg: Any) -> Trajectory | None:
        """The message's trajectory in world joint names, starting at its header stamp."""
        unknown = [str(j) for j in msg.joint_names if str(j) not in self.ros_joints]
        if unknown:
            raise _InvalidGoalError(
                INVALID_JOINTS,
                f"joints {unknown} are not controlled by {self.spec.name} "
                f"({', '.join(self.ros_joints)})",
            )
        trajectory = trajectory_from_message(msg)
        if trajectory is None:
            return None
        joints = tuple(self.names.world_joint(j) for j in trajectory.joints)
        trajectory = replace(trajectory, joints=joints)
        stamp = duration_seconds(msg.header.stamp)
        delay = stamp - self.world.time if stamp > 0 else 0.0
        if delay + trajectory.duration < 0:
            raise _InvalidGoalError(INVALID_GOAL, "the trajectory ends in the past")
        if delay > 0:  # starts later: shift every point
            points = tuple(replace(p, time=p.time + delay) for p in trajectory.points)
            trajectory = Trajectory(trajectory.joints, points)
        return trajectory

    def _follow(self, trajectory: Trajectory) -> None:
        for joint in trajectory.joints:
            spec = self.world.drives.spec(joint)
            if spec.mode is not DriveMode.POSITION:
                self.world.drives.set_spec(joint, spec.with_changes(mode=DriveMode.POSITION))
        self.follower.start(trajectory, self.world.time)
        self._trajectory, self._start = self.follower.active, self.world.time
        _names, self._qpos, self._dofs = self.world.joint_indices(trajectory.joints)
        self._path_check = _tolerance_check(trajectory.joints, self._path_tol)
        self._in_controller = np.array([self.joints.index(j) for j in trajectory.joints], np.intp)
        self._goal_check = _tolerance_check(trajectory.joints, self._goal_tol)

    def _hold(self) -> None:
        """Stop where the joints are (as the real controller's hold position)."""
        self.follower.cancel()
        self._trajectory = None
        actual = self.world.joint_positions(self.joints)
        for joint in self.joints:
            self.world.drives.set_position(joint, actual[joint], 0.0)

    def _stop(self) -> None:
        self.follower.cancel()
        self._trajectory = None
        if self._goal is not None:
            self._goal.abort(self._result(INVALID_GOAL, "simulation reset"))
            self._goal = None

    def _preempt(self, why: str) -> None:
        if self._goal is not None:
            self._goal.canceled(self._result(SUCCESSFUL, why), text=why)
            self._goal = None

    def _on_command(self, msg: Any) -> None:
        try:
            trajectory = self._trajectory_of(msg)
        except SimError as exc:
            _log.warning("%s: command rejected: %s", self.command_topic, exc)
            return
        self._preempt("preempted by a command on the topic")
        if trajectory is None:
            self._hold()
        else:
            self._follow(trajectory)

    def _on_goal(self, goal: AnyServerGoal) -> None:
        msg = goal.goal
        try:
            _refuse_multi_dof(msg)
            trajectory = self._trajectory_of(msg.trajectory)
            if trajectory is None:
                raise _InvalidGoalError(INVALID_GOAL, "the trajectory has no points")
        except _InvalidGoalError as exc:
            goal.reject(self._result(exc.code, str(exc)), text=str(exc))
            return
        except SimError as exc:
            goal.reject(self._result(INVALID_GOAL, str(exc)), text=str(exc))
            return
        self._preempt("preempted by a new goal")
        self._path_tol = self._tolerances(msg.path_tolerance, "trajectory")
        self._goal_tol = self._tolerances(msg.goal_tolerance, "goal")
        requested = duration_seconds(msg.goal_time_tolerance)
        self._goal_time = requested if requested > 0 else self.spec.goal_time
        goal.accept()
        self._goal = goal
        self._follow(trajectory)

    def _tolerances(self, given: Any, kind: str) -> dict[str, float]:
        """World joint -> position tolerance: the scene's constraints, overridden by the
        goal's (0 keeps the default, -1 removes it)."""
        tolerances: dict[str, float] = {}
        for joint in self.ros_joints:
            limit = self.spec.constraints.get(joint)
            value = (limit.trajectory if kind == "trajectory" else limit.goal) if limit else 0.0
            if value > 0:
                tolerances[self.names.world_joint(joint)] = value
        for tol in given:
            name = str(tol.name)
            if name not in self.ros_joints:
                continue
            world_name = self.names.world_joint(name)
            if tol.position < 0:
                tolerances.pop(world_name, None)
            elif tol.position > 0:
                tolerances[world_name] = float(tol.position)
        return tolerances

    def _on_cancel(self, goal: AnyServerGoal) -> None:
        if goal is self._goal:
            self._goal = None
            self._hold()
        goal.canceled(self._result(SUCCESSFUL, "canceled"))

    # ---- every step ------------------------------------------------------------------------

    def _update(self) -> None:
        trajectory = self._trajectory
        if trajectory is None:
            return
        t = self.world.time - self._start
        duration = trajectory.duration
        goal = self._goal
        if goal is None:
            if t >= duration:
                self._trajectory = None
            return
        # What the follower aims at now (the last point, at rest, from the end on).
        errors = trajectory.aim(t)[0] - self.world.data.qpos[self._qpos]
        if t < duration:
            path = self._path_check
            if path is not None:
                over = np.abs(errors[path[0]]) > path[1]
                if over.any():
                    i = int(np.argmax(over))
                    joint, tol = trajectory.joints[int(path[0][i])], float(path[1][i])
                    text = (
                        f"path tolerance violated: joint {self.names.to_ros[joint]} error "
                        f"{float(errors[path[0][i]]):.4g} exceeds {tol:g}"
                    )
                    self._goal = None
                    self._hold()
                    goal.abort(self._result(PATH_TOLERANCE_VIOLATED, text), text=text)
            return
        check = self._goal_check
        within = check is None or bool(np.all(np.abs(errors[check[0]]) <= check[1]))
        stopped = bool(
            np.all(np.abs(self.world.data.qvel[self._dofs]) <= self.spec.stopped_velocity_tolerance)
        )
        if within and (stopped or not self._goal_tol):
            self._goal, self._trajectory = None, None
            goal.succeed(self._result(SUCCESSFUL))
        elif t > duration + self._goal_time:
            by_joint = {j: float(e) for j, e in zip(trajectory.joints, errors, strict=True)}
            worst = max(self._goal_tol, key=lambda j: abs(by_joint.get(j, 0.0)) - self._goal_tol[j])
            text = (
                f"goal tolerance violated: joint {self.names.to_ros[worst]} error "
                f"{by_joint[worst]:.4g} exceeds {self._goal_tol[worst]:g} "
                f"{t - duration:.3g} s after the trajectory's end"
            )
            self._goal, self._trajectory = None, None
            goal.abort(self._result(GOAL_TOLERANCE_VIOLATED, text), text=text)

    def _points(self) -> tuple[Any, Any, Any, Any]:
        """(desired, actual, error, output) JointTrajectoryPoints over the controller's
        joints, output being the drives' position targets (what the controller commands);
        built only when feedback or state is due, from index arrays: no per-joint dicts."""
        data = self.world.data
        actual_q, actual_v = data.qpos[self._all_qpos], data.qvel[self._all_dofs]
        desired_v = np.zeros(len(self.joints))
        t = 0.0
        trajectory = self._trajectory
        if trajectory is not None:
            desired_q = actual_q.copy()
            t = self.world.time - self._start
            positions, velocities = trajectory.sample(min(t, trajectory.duration))
            desired_q[self._in_controller] = positions
            desired_v[self._in_controller] = velocities
        else:
            desired_q = self.world.drives.positions(self._actuators)
        stamp = self._stamps.time(max(t, 0.0))
        duration = self._stamps.cls("builtin_interfaces/Duration")(
            sec=stamp.sec, nanosec=stamp.nanosec
        )
        point_class = self._stamps.cls("trajectory_msgs/JointTrajectoryPoint")

        def point(q: Vector, v: Vector) -> Any:
            return point_class(
                positions=q,
                velocities=v,
                accelerations=np.zeros(0),
                effort=np.zeros(0),
                time_from_start=duration,
            )

        return (
            point(desired_q, desired_v),
            point(actual_q, actual_v),
            point(desired_q - actual_q, desired_v - actual_v),
            point(self.world.drives.positions(self._actuators), np.zeros(0)),
        )

    def _message(self, name: str) -> Any:
        """`name` (the state or the feedback) now, in the registry's layout: header, joint
        names and the points (ROS 1 and ROS 2 feedback: desired, actual, error; ROS 2 state:
        reference, feedback, error, output), multi-DOF fields empty, speed scaling 1."""
        fields = self._fields.get(name)
        if fields is None:
            schema = self.connector.registry.schema(name)
            fields = self._fields[name] = frozenset(f.name for f in schema.fields)
        desired, actual, error, output = self._points()
        values: dict[str, Any] = {
            "header": self._stamps.header(self.world.time),
            "joint_names": list(self.ros_joints),
            "error": error,
        }
        if "reference" in fields:
            values.update(reference=desired, feedback=actual, output=output)
        else:
            values.update(desired=desired, actual=actual)
        if "multi_dof_joint_names" in fields:
            values["multi_dof_joint_names"] = []
            empty = self._stamps.cls("trajectory_msgs/MultiDOFJointTrajectoryPoint")
            zero = self._stamps.cls("builtin_interfaces/Duration")
            for field in fields - values.keys():
                if field.startswith("multi_dof_"):
                    values[field] = empty(
                        transforms=[], velocities=[], accelerations=[], time_from_start=zero(0, 0)
                    )
        if "speed_scaling_factor" in fields:
            values["speed_scaling_factor"] = 1.0
        return self._stamps.cls(name)(**values)

    def _publish_feedback(self) -> None:
        goal = self._goal
        if goal is None:
            return
        goal.publish_feedback(self._message(f"{ACTION}Feedback"))

    def _publish_state(self) -> None:
        self.connector.publish(
            self.state_topic, self._message("control_msgs/JointTrajectoryControllerState")
        )


_Check = tuple[NDArray[np.intp], NDArray[np.float64]]


def _refuse_multi_dof(goal: Any) -> None:
    """INVALID_JOINTS for a ROS 2 goal that moves multi-DOF (planar, floating) joints."""
    multi_dof = getattr(goal, "multi_dof_trajectory", None)
    if multi_dof is not None and (multi_dof.joint_names or multi_dof.points):
        raise _InvalidGoalError(
            INVALID_JOINTS,
            f"multi_dof_trajectory moves {list(multi_dof.joint_names)} with "
            f"{len(multi_dof.points)} point(s): multi-DOF joints are not supported; "
            "expected an empty multi_dof_trajectory",
        )


def _tolerance_check(joints: tuple[str, ...], tolerances: dict[str, float]) -> _Check | None:
    """(indices into `joints`, tolerances) of the tolerances on `joints`, in the dict's
    order (the first violated one is reported); None when none applies."""
    pairs = [(joints.index(j), tol) for j, tol in tolerances.items() if j in joints]
    if not pairs:
        return None
    return np.array([i for i, _ in pairs], np.intp), np.array([t for _, t in pairs])


class _InvalidGoalError(SimError):
    """A goal the controller refuses, with the result's error code."""

    def __init__(self, code: int, text: str) -> None:
        super().__init__(text)
        self.code = code
