"""The arm's kinematic model on a MuJoCo MjModel: FK, Jacobians, limits and collision checks."""

from __future__ import annotations

import copy
from collections.abc import Mapping
from dataclasses import dataclass, field

import mujoco
import numpy as np
import numpy.typing as npt

from simbridge.errors import PlanningError
from simbridge.planning.geometry import FloatArray, Pose
from simbridge.planning.scene import PAYLOAD_GEOM

__all__ = ["ArmKinematics", "ArmSpec", "Contact", "niryo_one_arm"]

_BODY = mujoco.mjtObj.mjOBJ_BODY
_SITE = mujoco.mjtObj.mjOBJ_SITE
_JOINT = mujoco.mjtObj.mjOBJ_JOINT
_HINGE = int(mujoco.mjtJoint.mjJNT_HINGE)
_SLIDE = int(mujoco.mjtJoint.mjJNT_SLIDE)
# index permutations for a vectorised cross product
_NEXT = [1, 2, 0]
_PREV = [2, 0, 1]

# Per-geom roles for collision filtering.
_IGNORED, _STATIC, _ROBOT = 0, 1, 2


@dataclass(frozen=True)
class ArmSpec:
    """Names that tie a planner to a model: arm joints, tool and base frames, held joints.

    ``fixed_joints`` pins joints the planner does not move (e.g. open gripper fingers) for
    collision checks. ``safety_margin`` is the clearance (m) below which geoms count as touching.
    """

    joint_names: tuple[str, ...]
    tool_frame: str
    base_frame: str
    fixed_joints: Mapping[str, float] = field(default_factory=dict)
    velocity_limits: tuple[float, ...] | None = None
    acceleration_limits: tuple[float, ...] = ()
    safety_margin: float = 0.004


def niryo_one_arm(
    tool_frame: str = "tool_link", gripper_opening: float = 0.035, safety_margin: float = 0.004
) -> ArmSpec:
    """The shipped Niryo One: joint_1..joint_6, tool_link, base_link, fingers held open.

    Velocity limits are the URDF's 2 rad/s; acceleration limits (not part of URDF) are a
    conservative 4 rad/s^2.
    """
    return ArmSpec(
        joint_names=tuple(f"joint_{i}" for i in range(1, 7)),
        tool_frame=tool_frame,
        base_frame="base_link",
        fixed_joints={"left_finger_joint": gripper_opening, "right_finger_joint": gripper_opening},
        velocity_limits=(2.0,) * 6,
        acceleration_limits=(4.0,) * 6,
        safety_margin=safety_margin,
    )


@dataclass(frozen=True)
class Contact:
    """A pair of geoms closer than the safety margin, named by their bodies/geoms."""

    first: str
    second: str
    distance: float

    def describe(self) -> str:
        """'a <-> b (d mm)' for error messages."""
        return f"{self.first} <-> {self.second} ({self.distance * 1000:.1f} mm)"


def _lookup(model: mujoco.MjModel, kind: mujoco.mjtObj, name: str) -> int:
    return int(mujoco.mj_name2id(model, kind, name))


def _names(model: mujoco.MjModel, kind: mujoco.mjtObj, count: int) -> list[str]:
    return [mujoco.mj_id2name(model, kind, i) or f"#{i}" for i in range(count)]


class ArmKinematics:
    """Forward kinematics, Jacobians and collision checks for one serial arm in an MjModel.

    The model is copied (the planner sets its own collision margins). Poses are expressed in
    ``spec.base_frame``. Collisions count between a moving robot geom and either another robot
    geom or a static (world-welded) geom; free objects such as a cube are ignored.
    """

    def __init__(self, model: mujoco.MjModel, spec: ArmSpec) -> None:
        self.spec = spec
        self.model = copy.deepcopy(model)
        self.data = mujoco.MjData(self.model)
        m = self.model
        self.joint_ids = self._joint_ids(spec.joint_names)
        for jid, name in zip(self.joint_ids, spec.joint_names, strict=True):
            if int(m.jnt_type[jid]) not in (_HINGE, _SLIDE):
                raise PlanningError(f"joint {name!r} is not a hinge or slide joint")
        self.qpos_index = np.array([m.jnt_qposadr[j] for j in self.joint_ids], dtype=np.int64)
        self.dof_index = np.array([m.jnt_dofadr[j] for j in self.joint_ids], dtype=np.int64)
        self.revolute = np.array([int(m.jnt_type[j]) == _HINGE for j in self.joint_ids])
        self.lower = np.array([m.jnt_range[j][0] for j in self.joint_ids])
        self.upper = np.array([m.jnt_range[j][1] for j in self.joint_ids])
        for jid, name in zip(self.joint_ids, spec.joint_names, strict=True):
            if not m.jnt_limited[jid]:
                raise PlanningError(f"joint {name!r} has no position limits in the model")
        self.velocity_limits = self._per_joint(spec.velocity_limits, 1.0, "velocity")
        self.acceleration_limits = self._per_joint(spec.acceleration_limits, 2.0, "acceleration")
        fixed_ids = self._joint_ids(tuple(spec.fixed_joints))
        self._fixed = [
            (int(m.jnt_qposadr[j]), float(v))
            for j, v in zip(fixed_ids, spec.fixed_joints.values(), strict=True)
        ]
        self._tool_body, self._tool_site = self._frame(spec.tool_frame, "tool")
        self._base_body, self._base_site = self._frame(spec.base_frame, "base")
        self._payload = _lookup(m, mujoco.mjtObj.mjOBJ_GEOM, PAYLOAD_GEOM)
        if self._payload >= 0:  # compiled with collisions off; roles gate it from here on
            payload_body = m.geom_bodyid[self._payload]
            m.geom_contype[self._payload] = m.geom_conaffinity[self._payload] = 1
            m.body_contype[payload_body] |= 1
            m.body_conaffinity[payload_body] |= 1
        self._roles = self._geom_roles()
        self.holding = False
        m.geom_margin[:] = spec.safety_margin
        self._geom_names = self._describe_geoms()
        self._joint_bodies = [int(m.jnt_bodyid[j]) for j in self.joint_ids]
        self.set_configuration(np.clip(np.zeros(self.dof), self.lower, self.upper))

    # --- set-up helpers -------------------------------------------------------------------

    def _joint_ids(self, names: tuple[str, ...]) -> list[int]:
        ids = []
        for name in names:
            jid = _lookup(self.model, _JOINT, name)
            if jid < 0:
                known = _names(self.model, _JOINT, self.model.njnt)
                raise PlanningError(f"no joint {name!r} in the model; joints: {known}")
            ids.append(jid)
        return ids

    def _per_joint(self, values: tuple[float, ...] | None, default: float, what: str) -> FloatArray:
        if not values:
            return np.full(self.dof, default)
        if len(values) != self.dof or min(values) <= 0:
            raise PlanningError(
                f"{what} limits must be {self.dof} positive numbers, got {values!r}"
            )
        return np.array(values, dtype=np.float64)

    def _frame(self, name: str, role: str) -> tuple[int, int]:
        body = _lookup(self.model, _BODY, name)
        if body >= 0:
            return body, -1
        site = _lookup(self.model, _SITE, name)
        if site >= 0:
            return -1, site
        bodies = _names(self.model, _BODY, self.model.nbody)
        raise PlanningError(f"{role} frame {name!r} is neither a body nor a site; bodies: {bodies}")

    def _geom_roles(self) -> npt.NDArray[np.int64]:
        m = self.model
        first_body = int(m.jnt_bodyid[self.joint_ids[0]])
        robot_root = int(m.body_parentid[first_body])
        # robot = the subtree of the body carrying the first arm joint's parent
        in_robot = np.zeros(m.nbody, dtype=bool)
        for body in range(m.nbody):
            b = body
            while b > 0 and b != robot_root:
                b = int(m.body_parentid[b])
            in_robot[body] = b == robot_root and (body != 0 or robot_root == 0)
        roles = np.full(m.ngeom, _IGNORED, dtype=np.int64)
        for geom in range(m.ngeom):
            if m.geom_contype[geom] == 0 and m.geom_conaffinity[geom] == 0:
                continue
            body = int(m.geom_bodyid[geom])
            if m.body_weldid[body] == 0:
                roles[geom] = _STATIC
            elif in_robot[body]:
                roles[geom] = _ROBOT
        if self._payload >= 0:
            roles[self._payload] = _IGNORED
        return roles

    @property
    def has_payload(self) -> bool:
        """Whether the model carries a payload geom (see :func:`build_planning_model`)."""
        return self._payload >= 0

    def hold(self, holding: bool) -> None:
        """Count the payload geom in collision checks (True) or ignore it (False)."""
        if self._payload >= 0:
            self._roles[self._payload] = _ROBOT if holding else _IGNORED
        self.holding = holding

    def _describe_geoms(self) -> list[str]:
        m = self.model
        names = []
        for geom in range(m.ngeom):
            geom_name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, geom)
            body_name = mujoco.mj_id2name(m, _BODY, int(m.geom_bodyid[geom])) or "world"
            names.append(geom_name if geom_name else body_name)
        return names

    # --- configuration and forward kinematics ----------------------------------------------

    @property
    def dof(self) -> int:
        """Number of arm joints."""
        return len(self.joint_ids)

    def within_limits(self, q: FloatArray, tolerance: float = 1e-9) -> bool:
        """True when every joint value lies inside its position limits."""
        return bool(np.all(q >= self.lower - tolerance) and np.all(q <= self.upper + tolerance))

    def check_limits(self, q: FloatArray, what: str) -> None:
        """Raise PlanningError naming the first joint outside its limits."""
        if q.shape != (self.dof,) or not np.all(np.isfinite(q)):
            raise PlanningError(f"{what}: expected {self.dof} finite joint values, got {q!r}")
        for i, name in enumerate(self.spec.joint_names):
            if not self.lower[i] - 1e-6 <= q[i] <= self.upper[i] + 1e-6:
                raise PlanningError(
                    f"{what}: {name} = {q[i]:.4f} rad is outside its limits "
                    f"[{self.lower[i]:.4f}, {self.upper[i]:.4f}]"
                )

    def set_configuration(self, q: FloatArray) -> None:
        """Write the arm joints (and the held joints) and update frame poses."""
        qpos = self.data.qpos
        qpos[self.qpos_index] = q
        for address, value in self._fixed:
            qpos[address] = value
        mujoco.mj_kinematics(self.model, self.data)

    def _world_frame(self, body: int, site: int) -> tuple[FloatArray, FloatArray]:
        if body >= 0:
            return self.data.xpos[body].copy(), self.data.xmat[body].reshape(3, 3).copy()
        return self.data.site_xpos[site].copy(), self.data.site_xmat[site].reshape(3, 3).copy()

    def _base_world(self) -> tuple[FloatArray, FloatArray]:
        return self._world_frame(self._base_body, self._base_site)

    def tool_world(self) -> tuple[FloatArray, FloatArray]:
        """Tool position and rotation in the world frame for the current configuration."""
        return self._world_frame(self._tool_body, self._tool_site)

    def to_world(self, pose: Pose) -> tuple[FloatArray, FloatArray]:
        """A base-frame pose as a world-frame position and rotation."""
        base_pos, base_rot = self._base_world()
        return base_pos + base_rot @ pose.position, base_rot @ pose.rotation

    def forward(self, q: FloatArray) -> Pose:
        """Tool pose in the base frame at configuration ``q``."""
        self.set_configuration(q)
        pos, rot = self.tool_world()
        base_pos, base_rot = self._base_world()
        return Pose.from_matrix(base_rot.T @ (pos - base_pos), base_rot.T @ rot)

    def jacobian(self) -> FloatArray:
        """6 x dof world-frame Jacobian (linear rows first) of the tool at the current state."""
        tool_pos, _ = self.tool_world()
        axes = self.data.xaxis[self.joint_ids]
        arm = tool_pos - self.data.xanchor[self.joint_ids]
        lever = axes[:, _NEXT] * arm[:, _PREV] - axes[:, _PREV] * arm[:, _NEXT]
        linear = np.where(self.revolute[:, None], lever, axes)
        angular = np.where(self.revolute[:, None], axes, 0.0)
        return np.vstack([linear.T, angular.T])

    # --- collisions ----------------------------------------------------------------------

    def contacts(self, q: FloatArray) -> list[Contact]:
        """Pairs of relevant geoms closer than the safety margin at configuration ``q``."""
        self.set_configuration(q)
        mujoco.mj_collision(self.model, self.data)
        found = []
        roles = self._roles
        margin = self.spec.safety_margin
        for contact in self.data.contact[: self.data.ncon]:
            a, b = int(contact.geom1), int(contact.geom2)
            if min(roles[a], roles[b]) == _IGNORED or max(roles[a], roles[b]) != _ROBOT:
                continue
            if contact.dist < margin:
                found.append(Contact(self._geom_names[a], self._geom_names[b], float(contact.dist)))
        return found

    def in_collision(self, q: FloatArray) -> bool:
        """True when some relevant pair of geoms is closer than the safety margin."""
        self.set_configuration(q)
        mujoco.mj_collision(self.model, self.data)
        ncon = self.data.ncon
        if ncon == 0:
            return False
        roles = self._roles
        geoms = self.data.contact.geom[:ncon]
        dist = self.data.contact.dist[:ncon]
        ra, rb = roles[geoms[:, 0]], roles[geoms[:, 1]]
        relevant = (np.minimum(ra, rb) != _IGNORED) & (np.maximum(ra, rb) == _ROBOT)
        return bool(np.any(relevant & (dist < self.spec.safety_margin)))
