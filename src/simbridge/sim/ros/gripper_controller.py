"""ros_control's gripper_action_controller for one robot: `<ns>/<name>/gripper_cmd`
(control_msgs/GripperCommand). The joint's drive goes to `position` with its force limited
to `max_effort` (> 0); the goal succeeds within `goal_tolerance` (reached_goal), or once
the joint has moved slower than `stall_velocity_threshold` for `stall_timeout` seconds
(stalled: aborted, or succeeded with `allow_stalling`, as when holding an object)."""

from __future__ import annotations

from typing import Any

from simbridge.connector import (
    ActionServer,
    AnyServerGoal,
    Connector,
    Ros2ActionServer,
    action_server,
)
from simbridge.sim.control.drive import DriveMode, DriveSpec
from simbridge.sim.ros.names import RobotNames, resolve_name
from simbridge.sim.scene.spec import GripperControllerSpec
from simbridge.sim.world.callbacks import CallbackHandle
from simbridge.sim.world.world import World

__all__ = ["GripperActionController"]

ACTION = "control_msgs/GripperCommand"


class GripperActionController:
    """One gripper_action_controller; its work runs on the simulation thread."""

    def __init__(
        self,
        world: World,
        connector: Connector,
        names: RobotNames,
        namespace: str,
        spec: GripperControllerSpec,
    ) -> None:
        self.world, self.connector, self.spec = world, connector, spec
        self.joint = names.world_joint(spec.joint)
        self._configured: DriveSpec = world.drives.spec(self.joint)  # SimError if undriven
        self.action_name = f"{resolve_name(namespace, spec.name)}/gripper_cmd"
        self._goal: AnyServerGoal | None = None
        self._target = 0.0
        self._last_movement = 0.0
        self._server: ActionServer | Ros2ActionServer | None = None
        self._callbacks: list[CallbackHandle] = []

    def start(self) -> GripperActionController:
        """Serve the action; check the goal after every step."""
        world = self.world
        self._server = action_server(
            self.connector,
            self.action_name,
            ACTION,
            lambda goal: world.post(lambda: self._on_goal(goal)),
            lambda goal: world.post(lambda: self._on_cancel(goal)),
            clock=lambda: world.time,
        )
        self._callbacks = [
            world.add_step_callback(lambda _w: self._update()),
            world.add_step_callback(
                lambda _w: self._publish_feedback(), 1.0 / self.spec.action_monitor_rate
            ),
        ]
        return self

    def close(self) -> None:
        """Stop serving (the connector stays open)."""
        for callback in self._callbacks:
            callback.remove()
        self._callbacks.clear()
        if self._server is not None:
            self._server.close()
            self._server = None

    def _message(self, kind: str, stalled: bool = False, reached: bool = False) -> Any:
        return self.connector.registry.new(
            f"{ACTION}{kind}",
            position=self.world.joint_positions([self.joint])[self.joint],
            effort=self.world.joint_efforts([self.joint])[self.joint],
            stalled=stalled,
            reached_goal=reached,
        )

    def _on_goal(self, goal: AnyServerGoal) -> None:
        if self._goal is not None:
            self._goal.canceled(self._message("Result"), text="preempted by a new goal")
        command = goal.goal.command
        effort = float(command.max_effort)
        limit = effort if effort > 0 else self._configured.force_limit
        self.world.drives.set_spec(
            self.joint, self._configured.with_changes(mode=DriveMode.POSITION, force_limit=limit)
        )
        self._target = float(command.position)
        self.world.drives.set_position(self.joint, self._target, 0.0)
        self._last_movement = self.world.time
        goal.accept()
        self._goal = goal

    def _on_cancel(self, goal: AnyServerGoal) -> None:
        if goal is self._goal:
            self._goal = None
            position = self.world.joint_positions([self.joint])[self.joint]
            self.world.drives.set_position(self.joint, position, 0.0)
        goal.canceled(self._message("Result"))

    def _update(self) -> None:
        goal = self._goal
        if goal is None:
            return
        position = self.world.joint_positions([self.joint])[self.joint]
        velocity = self.world.joint_velocities([self.joint])[self.joint]
        if abs(self._target - position) < self.spec.goal_tolerance:
            self._goal = None
            goal.succeed(self._message("Result", reached=True))
            return
        now = self.world.time
        if abs(velocity) >= self.spec.stall_velocity_threshold:
            self._last_movement = now
        elif now - self._last_movement > self.spec.stall_timeout:
            self._goal = None
            result = self._message("Result", stalled=True)
            if self.spec.allow_stalling:
                goal.succeed(result, text="stalled")
            else:
                goal.abort(result, text="stalled")

    def _publish_feedback(self) -> None:
        if self._goal is not None:
            self._goal.publish_feedback(self._message("Feedback"))
