"""Action spaces mapped onto the world's drives: joint or end-effector deltas, gripper, wheels.

Every adapter turns one action (a point of its `space`, in the units documented on each
class) into drive targets, exactly as the ROS command interfaces do: position targets on
the joint drives (`/joint_group_position_controller/command`) and a differential-drive
controller for twists (`/cmd_vel`). `controls` returns None when the drives' `ctrl`
(already in the world's data) holds for every coming physics step, or one row per step.
`JointDelta` and `EndEffectorDelta` (position only) also act on all the worlds of a vector
env at once (`apply_many` on a `WorldBatch`), with the bits `apply` gives each world.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence

import mujoco
import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray

from simbridge.errors import GymError
from simbridge.gym.batch import WorldBatch
from simbridge.gym.batch_math import BatchedDampedLeastSquares, BodyJacobians
from simbridge.sim.control import DiffDriveController, DiffDriveLimits, DriveMode
from simbridge.sim.control.drive_bank import Actuators
from simbridge.sim.ros import measure_wheels
from simbridge.sim.world import World

__all__ = [
    "ActionAdapter",
    "CombinedAction",
    "DampedLeastSquares",
    "EndEffectorDelta",
    "GripperCommand",
    "JointDelta",
    "TwistCommand",
    "WheelVelocity",
    "damped_least_squares",
    "index_of",
    "orientation_error",
]

FloatArray = NDArray[np.float64]


def index_of(addresses: list[int]) -> slice | list[int]:
    """A slice when the addresses are consecutive (cheaper to index with), else the list."""
    if addresses and addresses == list(range(addresses[0], addresses[0] + len(addresses))):
        return slice(addresses[0], addresses[0] + len(addresses))
    return addresses


def _box(low: Sequence[float], high: Sequence[float]) -> spaces.Box:
    return spaces.Box(np.array(low, np.float32), np.array(high, np.float32), dtype=np.float32)


class ActionAdapter(ABC):
    """Maps actions onto drive targets of the joints in `joints`."""

    space: spaces.Box
    joints: tuple[str, ...]
    batch_fields: tuple[str, ...] = ()
    """The derived fields `apply_many` reads from the `WorldBatch` (e.g. "xpos")."""

    @property
    def batched(self) -> bool:
        """Whether `apply_many` serves this adapter (no by default: the vector env then
        applies each world's action to its own world)."""
        return False

    def apply_many(self, batch: WorldBatch, actions: NDArray[np.float32]) -> None:
        """`apply` of every world in `batch` at once (`actions`: one row each), for the
        vector env, when `batched`. All the worlds' adapters come from one factory, so this
        one, bound to the first world, stands for all: every row must get the bits `apply`
        gives its world."""
        raise GymError(f"{type(self).__name__} has no batched form")

    def bind(self, world: World) -> None:
        """Check the joints exist and have drives; set drive modes."""
        for joint in self.joints:
            world.drives.spec(joint)

    def reset(self, world: World) -> None:  # noqa: B027 - optional hook
        """Forget internal state at the start of an episode (nothing by default)."""

    @abstractmethod
    def apply(self, world: World, action: NDArray[np.float32]) -> None:
        """Set the drive targets for `action` (clipped to `space` by the caller)."""

    def controls(self, world: World, action: NDArray[np.float32], steps: int) -> FloatArray | None:
        """Apply `action`; None when the drives' `ctrl` now in `world.data` holds for the
        next `steps` physics steps (the default), else one `ctrl` row per step."""
        self.apply(world, action)
        return None


class JointDelta(ActionAdapter):
    """Position-target increments, rad (or m) per step, in [-max_delta, max_delta] per joint.

    The new target is the previous target plus the action, clamped to the joint limits.
    """

    def __init__(self, joints: Sequence[str], max_delta: float = 0.05) -> None:
        if max_delta <= 0:
            raise GymError(f"JointDelta max_delta must be > 0 rad, got {max_delta}")
        self.joints = tuple(joints)
        self.max_delta = max_delta
        self.space = _box([-max_delta] * len(self.joints), [max_delta] * len(self.joints))
        self._actuators: Actuators = slice(0, 0)

    def bind(self, world: World) -> None:
        """Check the joints have drives; remember their actuators."""
        super().bind(world)
        self._actuators = world.drives.actuators(self.joints)

    def apply(self, world: World, action: NDArray[np.float32]) -> None:
        """Move each joint's position target by its entry of `action`."""
        drives = world.drives
        drives.set_positions(self._actuators, drives.positions(self._actuators) + action)

    @property
    def batched(self) -> bool:
        """Always."""
        return True

    def apply_many(self, batch: WorldBatch, actions: NDArray[np.float32]) -> None:
        """`apply` of every world: each row's targets move by its action."""
        batch.set_positions(self._actuators, batch.positions[:, self._actuators] + actions)


class DampedLeastSquares:
    """Joint step dq = J^T (J J^T + damping^2 I)^-1 error for (rows x cols) Jacobians (well
    behaved near singularities), with its work arrays kept between calls.

    Every product and the small symmetric solve are MuJoCo's own routines (`mju_*`): a
    microsecond each, where NumPy's `@` on these tiny matrices goes through BLAS and costs
    several, and `np.linalg.solve` tens, on every env step.
    """

    def __init__(self, rows: int, cols: int, damping: float) -> None:
        # [J | damping I]: its product with its transpose is J J^T + damping^2 I at once
        self.augmented = np.zeros((rows, cols + rows))
        self.augmented[:, cols:] = damping * np.eye(rows)
        self.system = np.zeros((rows, rows))
        self.solution = np.zeros(rows)
        self.step = np.zeros(cols + rows)
        self.cols = cols

    def solve(self, jacobian: FloatArray, error: FloatArray) -> FloatArray:
        """dq for `jacobian` (any layout) and `error`: a view of a work array, valid until
        the next call."""
        augmented, system, solution = self.augmented, self.system, self.solution
        augmented[:, : self.cols] = jacobian
        mujoco.mju_mulMatMatT(system, augmented, augmented)
        mujoco.mju_cholFactor(system, 0.0)
        mujoco.mju_cholSolve(solution, system, np.ascontiguousarray(error, np.float64))
        mujoco.mju_mulMatTVec(self.step, augmented, solution)  # J^T y, then damping y
        return self.step[: self.cols]


def damped_least_squares(jacobian: FloatArray, error: FloatArray, damping: float) -> FloatArray:
    """Joint step dq = J^T (J J^T + damping^2 I)^-1 error (see `DampedLeastSquares`)."""
    rows, cols = np.shape(jacobian)
    return DampedLeastSquares(rows, cols, damping).solve(jacobian, error)


def orientation_error(current: FloatArray, desired: FloatArray) -> FloatArray:
    """Rotation vector (small-angle, world frame) turning `current` towards `desired`."""
    error: FloatArray = 0.5 * np.sum(np.cross(current.T, desired.T), axis=0)
    return error


class EndEffectorDelta(ActionAdapter):
    """Cartesian steps of a body's origin in the world frame, m per step, in
    [-max_step, max_step] per axis.

    Each step solves damped least squares on the body's Jacobian over `joints` from their
    measured positions and sends the result as position targets. With `orientation` (a
    3x3 world rotation) the body's orientation is held there as well (6-D task).
    """

    batch_fields = ("xpos", "cdof", "subtree_com")

    def __init__(
        self,
        body: str,
        joints: Sequence[str],
        max_step: float = 0.02,
        *,
        orientation: FloatArray | None = None,
        damping: float = 0.05,
    ) -> None:
        if max_step <= 0:
            raise GymError(f"EndEffectorDelta max_step must be > 0 m, got {max_step}")
        self.body = body
        self.joints = tuple(joints)
        self.max_step = max_step
        self.orientation = None if orientation is None else np.asarray(orientation, np.float64)
        self.damping = damping
        self.space = _box([-max_step] * 3, [max_step] * 3)
        self._body_id = -1
        self._dofs: slice | list[int] = []
        self._qpos: slice | list[int] = []
        self._jacp = self._jacr = np.zeros((3, 0))
        self._actuators: Actuators = slice(0, 0)
        self._solver = DampedLeastSquares(3, len(self.joints), damping)
        self._solvers = (
            BatchedDampedLeastSquares(len(self.joints), damping) if damping > 0 else None
        )
        self._jacobians: BodyJacobians | None = None
        self._data: mujoco.MjData | None = None
        self._qpos_all = np.zeros(0)

    def bind(self, world: World) -> None:
        """Resolve the body, the joints' dof/qpos addresses and their actuators."""
        super().bind(world)
        self._actuators = world.drives.actuators(self.joints)
        body = mujoco.mj_name2id(world.model, mujoco.mjtObj.mjOBJ_BODY, self.body)
        if body < 0:
            raise GymError(f"EndEffectorDelta: no body {self.body!r} in the model")
        self._body_id = int(body)
        self._dofs = index_of([int(world.model.joint(j).dofadr[0]) for j in self.joints])
        self._qpos = index_of([int(world.model.joint(j).qposadr[0]) for j in self.joints])
        self._jacp = np.zeros((3, world.model.nv))
        self._jacr = np.zeros((3, world.model.nv))
        self._data, self._qpos_all = world.data, world.data.qpos  # a view, kept
        self._jacobians = BodyJacobians(world.model, self._body_id, self._dofs)

    def joint_step(self, world: World, delta: FloatArray) -> FloatArray:
        """Joint increments moving the body by `delta` (m) from the state in `world.data`
        (possibly a view of a work array, valid until the next call)."""
        model, data = world.model, world.data
        jacp, jacr = self._jacp, self._jacr
        if self.orientation is None:  # the rotational Jacobian is not needed
            mujoco.mj_jacBody(model, data, jacp, None, self._body_id)
            return self._solver.solve(jacp[:, self._dofs], delta)
        mujoco.mj_jacBody(model, data, jacp, jacr, self._body_id)
        rotation = data.xmat[self._body_id].reshape(3, 3)
        error = np.concatenate([delta, orientation_error(rotation, self.orientation)])
        jacobian = np.vstack([jacp[:, self._dofs], jacr[:, self._dofs]])
        return damped_least_squares(jacobian, error, self.damping)

    def apply(self, world: World, action: NDArray[np.float32]) -> None:
        """Aim the joints at measured position + the least-squares step for `action`."""
        data = world.data
        qpos = self._qpos_all if data is self._data else data.qpos
        targets = qpos[self._qpos] + self.joint_step(world, action.astype(np.float64))
        world.drives.set_positions(self._actuators, targets)

    @property
    def batched(self) -> bool:
        """Without an orientation to hold (the 3-D task), and with damping."""
        return self.orientation is None and self.damping > 0

    def apply_many(self, batch: WorldBatch, actions: NDArray[np.float32]) -> None:
        """`apply` of every world: Jacobians from the batch's kinematics, then one damped
        least-squares solve over all rows."""
        assert self._jacobians is not None, "bind() first"
        assert self._solvers is not None, "batched only with damping"
        solvers = self._solvers
        out = solvers.jacobian_buffer(batch.size)
        jacobian = self._jacobians(batch["xpos"], batch["cdof"], batch["subtree_com"], out)
        step = solvers.solve(jacobian, actions.T)
        batch.set_positions(self._actuators, batch.qpos[:, self._qpos] + step.T)

    def solve(self, world: World, position: FloatArray, iterations: int = 200) -> bool:
        """Teleport the joints kinematically so the body reaches `position` (and the held
        orientation); True when within 1 mm. Used to draw reachable start states."""
        for _ in range(iterations):
            error = np.asarray(position) - world.data.xpos[self._body_id]
            if float(np.linalg.norm(error)) < 1e-3:
                return True
            step = self.joint_step(world, np.clip(error, -0.05, 0.05))
            current = world.joint_positions(list(self.joints))
            world.set_joint_positions(
                {j: current[j] + float(dq) for j, dq in zip(self.joints, step, strict=True)}
            )
        return bool(np.linalg.norm(np.asarray(position) - world.data.xpos[self._body_id]) < 1e-3)


class GripperCommand(ActionAdapter):
    """One value in [-1, 1]: -1 closes the gripper joint fully, +1 opens it fully (linear)."""

    def __init__(self, joint: str) -> None:
        self.joints = (joint,)
        self.space = _box([-1.0], [1.0])
        self._range = (0.0, 0.0)

    def bind(self, world: World) -> None:
        """Read the joint's range (closed = lower limit, open = upper limit)."""
        super().bind(world)
        low, high = (float(v) for v in world.model.joint(self.joints[0]).range)
        self._range = (low, high)

    def apply(self, world: World, action: NDArray[np.float32]) -> None:
        """Aim the gripper joint at the commanded opening."""
        low, high = self._range
        world.drives.set_position(self.joints[0], low + (float(action[0]) + 1) / 2 * (high - low))


class CombinedAction(ActionAdapter):
    """Several adapters side by side; the action vector is their actions concatenated."""

    def __init__(self, parts: Sequence[ActionAdapter]) -> None:
        self.parts = tuple(parts)
        self.joints = tuple(j for part in self.parts for j in part.joints)
        self.space = _box(
            np.concatenate([p.space.low for p in self.parts]).tolist(),
            np.concatenate([p.space.high for p in self.parts]).tolist(),
        )
        self._splits = np.cumsum([p.space.shape[0] for p in self.parts])[:-1]

    def bind(self, world: World) -> None:
        """Bind every part."""
        for part in self.parts:
            part.bind(world)

    def reset(self, world: World) -> None:
        """Reset every part."""
        for part in self.parts:
            part.reset(world)

    def apply(self, world: World, action: NDArray[np.float32]) -> None:
        """Hand each part its slice of `action`."""
        for part, chunk in zip(self.parts, np.split(action, self._splits), strict=True):
            part.apply(world, chunk)


class WheelVelocity(ActionAdapter):
    """Wheel speeds (left, right), rad/s, in [-max_speed, max_speed]; velocity drives."""

    def __init__(self, left: str, right: str, max_speed: float = 10.0) -> None:
        self.joints = (left, right)
        self.space = _box([-max_speed] * 2, [max_speed] * 2)

    def bind(self, world: World) -> None:
        """Switch both wheel drives to velocity mode."""
        super().bind(world)
        for joint in self.joints:
            spec = world.drives.spec(joint)
            world.drives.set_spec(joint, spec.with_changes(mode=DriveMode.VELOCITY))

    def apply(self, world: World, action: NDArray[np.float32]) -> None:
        """Set both wheels' target speeds."""
        for joint, speed in zip(self.joints, action, strict=True):
            world.drives.set_velocity(joint, float(speed))


class TwistCommand(WheelVelocity):
    """Base twist (linear m/s along x, angular rad/s about z) within `limits`, through the
    same `DiffDriveController` (acceleration ramps included) that serves `/cmd_vel`."""

    def __init__(self, left: str, right: str, limits: DiffDriveLimits | None = None) -> None:
        super().__init__(left, right)
        self.limits = limits or DiffDriveLimits()
        v, w = self.limits.max_linear_velocity, self.limits.max_angular_velocity
        self.space = _box([-v, -w], [v, w])
        self.controller: DiffDriveController | None = None

    def bind(self, world: World) -> None:
        """Measure the wheels and build the controller."""
        super().bind(world)
        kinematics = measure_wheels(world, *self.joints)
        self.controller = DiffDriveController(kinematics, self.limits)

    def reset(self, world: World) -> None:
        """Stop: no command, no motion."""
        assert self.controller is not None, "bind() first"
        self.controller.reset()

    def apply(self, world: World, action: NDArray[np.float32]) -> None:
        """Command the controller at the current sim time."""
        assert self.controller is not None, "bind() first"
        self.controller.command(float(action[0]), float(action[1]), world.time)

    def controls(self, world: World, action: NDArray[np.float32], steps: int) -> FloatArray | None:
        """One row per physics step: the controller ramps the wheel speeds every step."""
        assert self.controller is not None, "bind() first"
        self.apply(world, action)
        rows = np.empty((steps, world.model.nu))
        for i in range(steps):
            left, right = self.controller.update(world.time + i * world.timestep)
            world.drives.set_velocity(self.joints[0], left)
            world.drives.set_velocity(self.joints[1], right)
            rows[i] = world.data.ctrl
        return rows
