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

    position_tolerance: float = 2e-4
    orientation_tolerance: float = math.radians(0.2)
    max_iterations: int = 100
    stall_iterations: int = 10
    restarts: int = 40
    candidates: int = 3
    damping: float = 0.02
    max_step: float = 0.4
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

    def _descend(
        self, q0: FloatArray, goal_pos: FloatArray, goal_rot: FloatArray, approach_only: bool
    ) -> _Attempt:
        opts, kin = self.options, self.kinematics
        q = np.clip(q0, kin.lower, kin.upper)
        w = opts.orientation_weight
        lam2 = opts.damping**2
        best = _Attempt(q.copy(), math.inf, math.inf)
        best_score, stalled = math.inf, 0
        for _ in range(opts.max_iterations):
            kin.set_configuration(q)
            pos_err, rot_err, angle = self._errors(goal_pos, goal_rot, approach_only)
            pos_norm = float(np.linalg.norm(pos_err))
            score = pos_norm + w * angle
            if score < best_score:
                stalled = 0 if score < 0.98 * best_score else stalled + 1
                best, best_score = _Attempt(q.copy(), pos_norm, angle), score
            else:
                stalled += 1
            if pos_norm < opts.position_tolerance and angle < opts.orientation_tolerance:
                break
            if stalled >= opts.stall_iterations:
                break
            jac = kin.jacobian()
            if approach_only:
                _, rot = kin.tool_world()
                axis = rot[:, 0]
                jac[3:] = (np.eye(3) - np.outer(axis, axis)) @ jac[3:]
            jac[3:] *= w
            err = np.concatenate([pos_err, w * rot_err])
            # Levenberg-Marquardt style: damping fades as the error shrinks
            damping = lam2 * min(1.0, score / 0.02) + 1e-8
            step = jac.T @ np.linalg.solve(jac @ jac.T + damping * np.eye(6), err)
            # joints pinned at a limit and pushed outward drop out; the rest re-solve
            pinned = ((q <= kin.lower) & (step < 0)) | ((q >= kin.upper) & (step > 0))
            if np.any(pinned):
                jac[:, pinned] = 0.0
                step = jac.T @ np.linalg.solve(jac @ jac.T + damping * np.eye(6), err)
            largest = float(np.max(np.abs(step)))
            if largest > opts.max_step:
                step *= opts.max_step / largest
            q = np.minimum(np.maximum(q + step, kin.lower), kin.upper)
        return best

    def _converged(self, attempt: _Attempt) -> bool:
        return (
            attempt.position_error < self.options.position_tolerance
            and attempt.angle_error < self.options.orientation_tolerance
        )

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
        for attempt_index in range(opts.restarts + 1):
            start = seed if attempt_index == 0 else rng.uniform(kin.lower, kin.upper)
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
