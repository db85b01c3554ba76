"""Motion plans for one arm of the line: a pick and place in the arm's base frame, among
the table, the pallet and the parts it must not touch, plus a straight retreat."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from simbridge.apps.line.task import PALLET_TOP, PART_SIZE
from simbridge.planning import (
    BoxObstacle,
    JointTrajectory,
    MoverOptions,
    MoverPlanner,
    Pose,
    top_down_orientation,
)

__all__ = ["GRASP_OFFSET", "ArmPlanner", "Transfer", "grasp_yaw", "pallet_box", "part_box"]

GRASP_OFFSET = 0.05
"""Distance (m) from the Niryo One's tool_link to grasp_link, between the finger pads."""
_PLACE_CLEARANCE = 0.008
"""How far above its resting height (m) a part is let go."""
_RETREAT = 0.05
"""How far (m) the tool rises straight up after letting a part go."""
_TABLE = BoxObstacle("table", (0.15, 0.0, -0.02), (0.45, 0.75, 0.02))


def grasp_yaw(bearing: float, part_yaw: float) -> float:
    """The gripper yaw that squares up to a cube at ``part_yaw`` (mod 90 deg), nearest the
    arm's bearing to it (which keeps the wrist near the middle of its range)."""
    quarter = math.pi / 2
    return bearing + (part_yaw - bearing + quarter / 2) % quarter - quarter / 2


@dataclass(frozen=True)
class Transfer:
    """The timed motions of one pick and place, in execution order."""

    pre_grasp: JointTrajectory
    grasp: JointTrajectory
    pick_up: JointTrajectory
    place: JointTrajectory
    retreat: JointTrajectory
    planning_time: float


class ArmPlanner:
    """Plans for the arm whose base_link stands at ``base_xy`` (world, unrotated)."""

    def __init__(self, base_xy: tuple[float, float], seed: int = 0) -> None:
        self.base = np.array([base_xy[0], base_xy[1], 0.0])
        self.seed = seed

    def _local(self, point: Sequence[float]) -> np.ndarray:
        local: np.ndarray = np.asarray(point, dtype=np.float64) - self.base
        return local

    def _obstacle(self, box: BoxObstacle) -> BoxObstacle:
        center = self._local(box.center)
        return BoxObstacle(box.name, (center[0], center[1], center[2]), box.half_extents)

    def _tool_pose(self, center: Sequence[float], yaw_world: float, lift: float) -> Pose:
        local = self._local(center)
        return Pose(
            [local[0], local[1], local[2] + GRASP_OFFSET + lift], top_down_orientation(yaw_world)
        )

    def transfer(
        self,
        joints: np.ndarray,
        pick: tuple[float, float, float, float],
        place: tuple[float, float, float],
        obstacles: Sequence[BoxObstacle] = (),
    ) -> Transfer:
        """Pick the cube at ``pick`` (centre x, y, z and yaw, world) and set it down squared
        to the world axes with its centre at ``place``; then rise clear of it."""
        x, y, z, yaw = pick
        local_pick = self._local((x, y, z))
        pick_yaw = grasp_yaw(math.atan2(local_pick[1], local_pick[0]), yaw)
        local_place = self._local(place)
        place_yaw = grasp_yaw(math.atan2(local_place[1], local_place[0]), 0.0)
        boxes = [self._obstacle(b) for b in (_TABLE, *obstacles)]
        planner = MoverPlanner.niryo_one(boxes, MoverOptions(seed=self.seed))
        pick_pose = self._tool_pose((x, y, z), pick_yaw, planner.options.grasp_drop)
        place_pose = self._tool_pose(place, place_yaw, _PLACE_CLEARANCE)
        plan = planner.plan(joints, pick_pose, place_pose)
        raised = place_pose.translated(dz=_RETREAT)
        retreat = planner.cartesian_motion(plan.place.end, raised, "retreat")
        return Transfer(
            pre_grasp=plan.pre_grasp,
            grasp=plan.grasp,
            pick_up=plan.pick_up,
            place=plan.place,
            retreat=planner.timed(retreat),
            planning_time=plan.planning_time,
        )


def part_box(name: str, center: Sequence[float]) -> BoxObstacle:
    """A part at ``center`` (world) as an obstacle, a little larger than the part (any yaw)."""
    half = PART_SIZE * 0.72
    return BoxObstacle(name, (center[0], center[1], center[2]), (half, half, PART_SIZE / 2))


def pallet_box(center_y: float, x: float) -> BoxObstacle:
    """The pallet, centred at (x, ``center_y``), as an obstacle."""
    return BoxObstacle("pallet", (x, center_y, PALLET_TOP / 2), (0.05, 0.05, PALLET_TOP / 2))
