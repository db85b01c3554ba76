"""Inverse kinematics: damped least squares within joint limits, restarts, collision checks."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from simbridge.errors import PlanningError
from simbridge.planning.geometry import FloatArray, Pose, rotation_error
from simbridge.planning.kinematics import ArmKinematics

__all__ = ["IKOptions", "IKSolver"]


@dataclass(frozen=True)
class IKOptions:
    """Tolerances and effort for :class:`IKSolver`.

    ``candidates`` is how many valid solutions restarts collect before the one nearest the seed
    wins (the seed's own solution is taken at once when valid).
    """

    position_tolerance: float = 5e-4
    orientation_tolerance: float = math.radians(0.5)
    max_iterations: int = 100
    stall_iterations: int = 8
    restarts: int = 40
    candidates: int = 3
    damping: float = 0.005
    max_step: float = 0.8
    orientation_weight: float = 0.3
    check_collisions: bool = True
    seed: int = 0


@dataclass
class _Attempt:
    q: FloatArray
    position_error: float
    angle_error: float


class IKSolver:
    """Solves tool-frame pose goals (in the arm's base frame) for joint values within limits."""

    def __init__(self, kinematics: ArmKinematics, options: IKOptions | None = None) -> None:
        self.kinematics = kinematics
        self.options = options or IKOptions()

    def _errors(
        self, goal_pos: FloatArray, goal_rot: FloatArray, approach_only: bool
    ) -> tuple[FloatArray, FloatArray, float]:
        pos, rot = self.kinematics.tool_world()
        if approach_only:
            axis, goal_axis = rot[:, 0], goal_rot[:, 0]
            cross = np.array(
                [
                    axis[1] * goal_axis[2] - axis[2] * goal_axis[1],
                    axis[2] * goal_axis[0] - axis[0] * goal_axis[2],
                    axis[0] * goal_axis[1] - axis[1] * goal_axis[0],
                ]
            )
            angle = math.atan2(float(np.linalg.norm(cross)), float(axis @ goal_axis))
            norm = float(np.linalg.norm(cross))
            rot_err = cross * (angle / norm) if norm > 1e-12 else np.zeros(3)
            if angle > math.pi / 2 and norm <= 1e-12:  # exactly opposite: any perpendicular turn
                rot_err = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
            return goal_pos - pos, np.asarray(rot_err), angle
        rot_err = rotation_error(rot, goal_rot)
        return goal_pos - pos, rot_err, float(np.linalg.norm(rot_err))

    def _evaluate(
        self, q: FloatArray, goal_pos: FloatArray, goal_rot: FloatArray, approach_only: bool
    ) -> tuple[_Attempt, FloatArray]:
        """Errors at ``q`` (kinematics left at ``q``) and the weighted 6-vector to reduce."""
        self.kinematics.set_configuration(q)
        pos_err, rot_err, angle = self._errors(goal_pos, goal_rot, approach_only)
        weighted = np.concatenate([pos_err, self.options.orientation_weight * rot_err])
        return _Attempt(q, float(np.linalg.norm(pos_err)), angle), weighted

    def _score(self, attempt: _Attempt) -> float:
        return attempt.position_error + self.options.orientation_weight * attempt.angle_error

    def _step(self, jac: FloatArray, err: FloatArray, q: FloatArray, lam2: float) -> FloatArray:
        """Damped least-squares step; joints pinned at a limit and pushed outward drop out."""
        kin, opts = self.kinematics, self.options
        step = jac.T @ np.linalg.solve(jac @ jac.T + lam2 * np.eye(6), err)
        pinned = ((q <= kin.lower) & (step < 0)) | ((q >= kin.upper) & (step > 0))
        if np.any(pinned):
            jac = jac.copy()
            jac[:, pinned] = 0.0
            step = jac.T @ np.linalg.solve(jac @ jac.T + lam2 * np.eye(6), err)
        largest = float(np.max(np.abs(step)))
        if largest > opts.max_step:
            step *= opts.max_step / largest
        return np.asarray(step)

    def _descend(
        self, q0: FloatArray, goal_pos: FloatArray, goal_rot: FloatArray, approach_only: bool
    ) -> _Attempt:
        """Levenberg-Marquardt from ``q0``: accepted steps relax the damping, rejected raise it."""
        opts, kin = self.options, self.kinematics
        current, err = self._evaluate(
            np.clip(q0, kin.lower, kin.upper), goal_pos, goal_rot, approach_only
        )
        lam2 = opts.damping**2
        stalled = 0
        jac = self._jacobian(approach_only)
        for _ in range(opts.max_iterations):
            if self._converged(current) or stalled >= opts.stall_iterations or lam2 > 1e4:
                break
            step = self._step(jac, err, current.q, lam2)
            q_new = np.minimum(np.maximum(current.q + step, kin.lower), kin.upper)
            candidate, err_new = self._evaluate(q_new, goal_pos, goal_rot, approach_only)
            if self._score(candidate) < self._score(current):
                gained = self._score(candidate) < 0.98 * self._score(current)
                stalled = 0 if gained else stalled + 1
                current, err = candidate, err_new
                jac = self._jacobian(approach_only)
                lam2 = max(lam2 * 0.3, 1e-12)
            else:
                stalled += 1
                lam2 *= 5.0
                kin.set_configuration(current.q)
        return current

    def _jacobian(self, approach_only: bool) -> FloatArray:
        """Weighted tool Jacobian at the kinematics' current configuration."""
        kin = self.kinematics
        jac = kin.jacobian()
        if approach_only:
            _, rot = kin.tool_world()
            axis = rot[:, 0]
            jac[3:] = (np.eye(3) - np.outer(axis, axis)) @ jac[3:]
        jac[3:] *= self.options.orientation_weight
        return jac

    def _converged(self, attempt: _Attempt) -> bool:
        return (
            attempt.position_error < self.options.position_tolerance
            and attempt.angle_error < self.options.orientation_tolerance
        )

    def _base_headings(self, goal_pos: FloatArray) -> list[float]:
        """First-joint angles facing the goal (and facing away), when that joint is a base yaw.

        For a vertical first axis the goal's azimuth about it fixes the first joint up to a
        half turn, so restarts seeded there land in the right basin far more often.
        """
        kin = self.kinematics
        kin.set_configuration(np.zeros(kin.dof))
        joint = kin.joint_ids[0]
        axis, anchor = kin.data.xaxis[joint].copy(), kin.data.xanchor[joint].copy()
        if not kin.revolute[0] or abs(abs(float(axis[2])) - 1.0) > 1e-6:
            return []
        sign = float(np.sign(axis[2]))
        tool_at_zero, _ = kin.tool_world()
        reach = tool_at_zero - anchor
        if math.hypot(reach[0], reach[1]) < 1e-6:  # tool on the axis at zero: no heading
            return []
        offset = goal_pos - anchor
        base = math.remainder(
            sign * (math.atan2(offset[1], offset[0]) - math.atan2(reach[1], reach[0])), 2 * math.pi
        )
        angles = [base + turn for turn in (0.0, math.pi, -math.pi)]
        return [a for a in angles if kin.lower[0] <= a <= kin.upper[0]]

    def solve(
        self,
        goal: Pose,
        seed_q: FloatArray,
        name: str = "goal",
        approach_only: bool = False,
        rng: np.random.Generator | None = None,
    ) -> FloatArray:
        """Joint values putting the tool at ``goal``; the valid solution nearest ``seed_q`` wins.

        ``approach_only`` frees the rotation about the tool's approach (x) axis, e.g. a top-down
        grasp with free yaw. Raises PlanningError naming the goal when nothing valid is found.
        """
        kin, opts = self.kinematics, self.options
        goal_pos, goal_rot = kin.to_world(goal)
        rng = rng if rng is not None else np.random.default_rng(opts.seed)
        seed = np.clip(np.asarray(seed_q, dtype=np.float64), kin.lower, kin.upper)
        solutions: list[FloatArray] = []
        closest = _Attempt(seed, math.inf, math.inf)
        colliding: list[str] = []
        headings = self._base_headings(goal_pos)
        for attempt_index in range(opts.restarts + 1):
            start = seed if attempt_index == 0 else rng.uniform(kin.lower, kin.upper)
            if attempt_index % 2 == 1 and headings:  # every other restart faces the goal
                start[0] = headings[(attempt_index // 2) % len(headings)]
            attempt = self._descend(start, goal_pos, goal_rot, approach_only)
            if attempt.position_error < closest.position_error:
                closest = attempt
            if not self._converged(attempt):
                continue
            if opts.check_collisions:
                contacts = kin.contacts(attempt.q)
                if contacts:
                    colliding.extend(c.describe() for c in contacts[:2])
                    continue
            if attempt_index == 0:
                return attempt.q
            solutions.append(attempt.q)
            if len(solutions) >= opts.candidates:
                break
        if solutions:
            return min(solutions, key=lambda q: float(np.sum((q - seed) ** 2)))
        if colliding:
            unique = list(dict.fromkeys(colliding))[:4]
            raise PlanningError(
                f"{name} {goal.describe()} is reachable only in collision: {'; '.join(unique)}"
            )
        raise PlanningError(
            f"{name} {goal.describe()} is unreachable: after {opts.restarts + 1} IK attempts the "
            f"closest tool pose was {closest.position_error * 1000:.1f} mm and "
            f"{math.degrees(closest.angle_error):.1f} deg away"
        )
