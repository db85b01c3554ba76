"""The tutorial's MoverService logic: pre-grasp, grasp, pick up and place trajectories."""

from __future__ import annotations

import itertools
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np
import numpy.typing as npt

from simbridge.assets import robot_urdf
from simbridge.errors import PlanningError
from simbridge.planning.geometry import FloatArray, Pose
from simbridge.planning.ik import IKOptions, IKSolver
from simbridge.planning.kinematics import ArmKinematics, niryo_one_arm
from simbridge.planning.rrt import JointPathPlanner, PathOptions
from simbridge.planning.scene import BoxObstacle, Payload, build_planning_model
from simbridge.planning.timing import JointTrajectory, time_parameterize

__all__ = ["DEFAULT_PAYLOAD", "MoverOptions", "MoverPlanner", "PickAndPlacePlan"]


@dataclass(frozen=True)
class MoverOptions:
    """How :class:`MoverPlanner` plans.

    ``grasp_drop`` is the tutorial's fixed 5 cm between pick_pose and the grasp; the limit scales
    multiply the arm's velocity/acceleration limits; ``cartesian_tolerance`` bounds how far (m)
    the tool may stray from the straight line while descending and lifting.
    ``grasp_symmetry`` is how many turns about the approach axis give the same grasp (2 for a
    two-finger gripper, 4 for a cube held by one): when a pose is out of reach, the planner
    tries the turned ones too (e.g. the tool turned 180 degrees when joint_6 runs out).
    ``approach_retries`` is how many other arm configurations above the object are tried when
    the straight descent is impossible from the first.
    """

    grasp_drop: float = 0.05
    velocity_scale: float = 0.5
    acceleration_scale: float = 0.5
    sample_period: float = 0.05
    cartesian_tolerance: float = 0.002
    free_yaw: bool = False
    grasp_symmetry: int = 2
    approach_retries: int = 4
    ik: IKOptions = field(default_factory=IKOptions)
    path: PathOptions = field(default_factory=PathOptions)
    seed: int = 0

    def __post_init__(self) -> None:
        if self.grasp_symmetry < 1:
            raise PlanningError(f"grasp_symmetry must be >= 1, got {self.grasp_symmetry}")
        for name in ("velocity_scale", "acceleration_scale"):
            value = getattr(self, name)
            if not 0 < value <= 1:
                raise PlanningError(f"{name} must be in (0, 1], got {value}")


@dataclass(frozen=True)
class PickAndPlacePlan:
    """The four trajectories of a pick and place, in execution order, and planning time (s)."""

    pre_grasp: JointTrajectory
    grasp: JointTrajectory
    pick_up: JointTrajectory
    place: JointTrajectory
    planning_time: float

    @property
    def trajectories(
        self,
    ) -> tuple[JointTrajectory, JointTrajectory, JointTrajectory, JointTrajectory]:
        """(pre_grasp, grasp, pick_up, place)."""
        return (self.pre_grasp, self.grasp, self.pick_up, self.place)


DEFAULT_PAYLOAD = Payload(body="grasp_link", half_extents=(0.025, 0.025, 0.025))


class MoverPlanner:
    """Plans pick and place like the tutorial's MoveIt mover, on an :class:`ArmKinematics`.

    Poses are tool-frame goals in the arm's base frame. pick_pose is the pre-grasp pose (above
    the object); the grasp is ``grasp_drop`` lower along a straight line; pick up retraces it;
    place goes to place_pose, checking the held payload (if the model has one) for collisions.
    Free-space moves use the joint-space planner.
    """

    def __init__(self, kinematics: ArmKinematics, options: MoverOptions | None = None) -> None:
        self.kinematics = kinematics
        self.options = options or MoverOptions()
        self.ik = IKSolver(kinematics, self.options.ik)
        self.paths = JointPathPlanner(kinematics, self.options.path)

    @classmethod
    def niryo_one(
        cls,
        obstacles: Sequence[BoxObstacle] = (),
        options: MoverOptions | None = None,
        tool_frame: str = "tool_link",
        payload: Payload | None = DEFAULT_PAYLOAD,
    ) -> MoverPlanner:
        """A planner for the shipped Niryo One URDF among ``obstacles`` (world = base frame).

        ``payload`` is the held object checked for collisions while placing (default: the
        tutorial's 5 cm cube centred between the finger pads).
        """
        model = build_planning_model(robot_urdf("niryo_one"), obstacles, payload)
        return cls(ArmKinematics(model, niryo_one_arm(tool_frame=tool_frame)), options)

    # --- single motions -------------------------------------------------------------------

    def solve_ik(
        self, pose: Pose, seed_q: FloatArray, name: str, rng: np.random.Generator
    ) -> FloatArray:
        """Collision-free joint values for a tool pose (or an equivalent turned grasp)."""
        first_error: PlanningError | None = None
        for turned in self._equivalent_poses(pose):
            try:
                return self.ik.solve(
                    turned, seed_q, name=name, approach_only=self.options.free_yaw, rng=rng
                )
            except PlanningError as exc:
                first_error = first_error or exc
        assert first_error is not None
        if self.options.grasp_symmetry > 1 and not self.options.free_yaw:
            raise PlanningError(
                f"{first_error} (also tried the {self.options.grasp_symmetry - 1} equivalent "
                "turned grasp(s))"
            ) from first_error
        raise first_error

    def _equivalent_poses(self, pose: Pose) -> list[Pose]:
        """The pose, then the pose turned about the tool's approach (x) axis by the symmetry."""
        if self.options.free_yaw:
            return [pose]
        count = self.options.grasp_symmetry
        turns = []
        for k in range(count):
            angle = 2.0 * math.pi * k / count
            c, s = math.cos(angle), math.sin(angle)
            about_x = np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])
            turns.append(Pose.from_matrix(pose.position, pose.rotation @ about_x))
        return turns

    def free_motion(
        self, start: FloatArray, pose: Pose, name: str, rng: np.random.Generator
    ) -> FloatArray:
        """Waypoints of a collision-free joint-space motion from ``start`` to a tool pose."""
        goal = self.solve_ik(pose, start, name, rng)
        return self.paths.plan(start, goal, name=name, seed=int(rng.integers(2**31)))

    def cartesian_motion(self, start: FloatArray, goal: Pose, name: str) -> FloatArray:
        """Waypoints moving the tool along a straight line to ``goal`` with fixed orientation."""
        kin = self.kinematics
        start_pose = kin.forward(start)
        local = IKSolver(kin, _continuation(self.options.ik))
        rng = np.random.default_rng(0)
        end = local.solve(goal, start, name=name, rng=rng)
        waypoints = [start, end]
        poses = [start_pose.position, goal.position]
        index, splits = 0, 0
        while index + 1 < len(waypoints):
            a, b = waypoints[index], waypoints[index + 1]
            pa, pb = poses[index], poses[index + 1]
            if self._off_line(a, b, pa, pb) <= self.options.cartesian_tolerance:
                index += 1
                continue
            splits += 1
            if splits > 32:
                raise PlanningError(f"{name} {goal.describe()}: no straight-line tool path found")
            middle_pos = (pa + pb) / 2
            middle = Pose(middle_pos, goal.orientation)
            waypoints.insert(index + 1, local.solve(middle, (a + b) / 2, name=name, rng=rng))
            poses.insert(index + 1, middle_pos)
        for a, b in itertools.pairwise(waypoints):
            if float(np.max(np.abs(b - a))) > 0.5:
                raise PlanningError(
                    f"{name} {goal.describe()}: the straight line needs a joint flip"
                )
            if not self.paths.edge_free(a, b):
                raise PlanningError(f"{name} {goal.describe()}: the straight-line motion collides")
        return np.vstack(waypoints)

    def _off_line(self, a: FloatArray, b: FloatArray, pa: FloatArray, pb: FloatArray) -> float:
        """Largest distance of the tool from segment pa-pb along the joint line a -> b."""
        line = pb - pa
        length2 = float(line @ line)
        worst = 0.0
        for s in np.linspace(0.0, 1.0, 9)[1:-1]:
            p = self.kinematics.forward(a + s * (b - a)).position
            u = float(np.clip((p - pa) @ line / length2, 0.0, 1.0)) if length2 > 0 else 0.0
            worst = max(worst, float(np.linalg.norm(p - (pa + u * line))))
        return worst

    def _approach(
        self, start: FloatArray, pick_pose: Pose, rng: np.random.Generator
    ) -> tuple[FloatArray, FloatArray]:
        """Pre-grasp then straight-down grasp waypoints.

        When the descent fails from the pre-grasp solution nearest ``start`` (an arm branch
        that cannot go lower, or joint_6 running out), other IK branches and the equivalent
        turned grasps are tried.
        """
        kin = self.kinematics
        name = "pre-grasp (pick_pose)"
        first_error: PlanningError | None = None
        for turned in self._equivalent_poses(pick_pose):
            seed = start
            for _ in range(1 + self.options.approach_retries):
                try:
                    pre_goal = self.ik.solve(
                        turned, seed, name=name, approach_only=self.options.free_yaw, rng=rng
                    )
                    above = kin.forward(pre_goal)
                    drop = np.array([0.0, 0.0, self.options.grasp_drop])
                    grasp_goal = Pose(above.position - drop, above.orientation)
                    grasp = self.cartesian_motion(pre_goal, grasp_goal, "grasp")
                except PlanningError as exc:
                    first_error = first_error or exc
                    if str(exc).startswith(name):
                        break  # IK (with its restarts) found no valid pre-grasp at all
                    seed = rng.uniform(kin.lower, kin.upper)
                    continue
                seed_path = int(rng.integers(2**31))
                return self.paths.plan(start, pre_goal, name=name, seed=seed_path), grasp
        assert first_error is not None
        raise first_error

    def timed(self, waypoints: FloatArray) -> JointTrajectory:
        """Time-parameterise waypoints within the scaled velocity and acceleration limits."""
        kin, opts = self.kinematics, self.options
        return time_parameterize(
            waypoints,
            kin.spec.joint_names,
            kin.velocity_limits * opts.velocity_scale,
            kin.acceleration_limits * opts.acceleration_scale,
            opts.sample_period,
        )

    # --- the service ----------------------------------------------------------------------

    def plan(self, joints: npt.ArrayLike, pick_pose: Pose, place_pose: Pose) -> PickAndPlacePlan:
        """Four trajectories (pre-grasp, grasp, pick up, place) from ``joints`` (radians)."""
        began = time.perf_counter()
        kin = self.kinematics
        start = np.asarray(joints, dtype=np.float64)
        if start.shape != (kin.dof,):
            raise PlanningError(f"expected {kin.dof} start joint values, got {start.size}")
        self.paths.check_state(start, "start configuration")
        rng = np.random.default_rng(self.options.seed)
        pre_grasp, grasp = self._approach(start, pick_pose, rng)
        pick_up = grasp[::-1].copy()
        kin.hold(True)
        try:
            place = self.free_motion(pick_up[-1], place_pose, "place (place_pose)", rng)
        finally:
            kin.hold(False)
        return PickAndPlacePlan(
            pre_grasp=self.timed(pre_grasp),
            grasp=self.timed(grasp),
            pick_up=self.timed(pick_up),
            place=self.timed(place),
            planning_time=time.perf_counter() - began,
        )


def _continuation(options: IKOptions) -> IKOptions:
    """IK settings for small moves: the seed's own solution or nothing (no far restarts)."""
    return replace(
        options,
        max_iterations=max(options.max_iterations, 200),
        restarts=0,
        candidates=1,
        max_step=min(options.max_step, 0.1),
    )
