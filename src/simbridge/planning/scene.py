"""Planning scenes: a robot MuJoCo model plus static box obstacles (a table, a wall)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import mujoco

from simbridge.errors import PlanningError
from simbridge.planning.geometry import FloatArray, matrix_to_quaternion, quaternion_to_matrix

__all__ = [
    "PAYLOAD_GEOM",
    "BoxObstacle",
    "Payload",
    "add_obstacles",
    "add_payload",
    "build_planning_model",
]

PAYLOAD_GEOM = "planning_payload"


@dataclass(frozen=True)
class BoxObstacle:
    """A static box in the world frame: centre (m), half extents (m), orientation (x, y, z, w)."""

    name: str
    center: tuple[float, float, float]
    half_extents: tuple[float, float, float]
    orientation: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 1.0)
    rgba: tuple[float, float, float, float] = field(default=(0.6, 0.45, 0.3, 1.0))

    def __post_init__(self) -> None:
        if not self.name:
            raise PlanningError("a box obstacle needs a non-empty name")
        if len(self.half_extents) != 3 or min(self.half_extents) <= 0:
            raise PlanningError(
                f"obstacle {self.name!r}: half extents must be 3 positive numbers, "
                f"got {self.half_extents!r}"
            )

    @property
    def rotation(self) -> FloatArray:
        """Orientation as a rotation matrix."""
        return quaternion_to_matrix(self.orientation)


def add_obstacles(spec: mujoco.MjSpec, obstacles: Sequence[BoxObstacle]) -> None:
    """Add each obstacle as a static box geom on the world body of ``spec``."""
    names = [o.name for o in obstacles]
    duplicates = sorted({n for n in names if names.count(n) > 1})
    if duplicates:
        raise PlanningError(f"obstacle names must be unique; repeated: {duplicates}")
    for obstacle in obstacles:
        x, y, z, w = matrix_to_quaternion(obstacle.rotation)
        spec.worldbody.add_geom(
            name=obstacle.name,
            type=mujoco.mjtGeom.mjGEOM_BOX,
            size=list(obstacle.half_extents),
            pos=list(obstacle.center),
            quat=[w, x, y, z],
            rgba=list(obstacle.rgba),
        )


@dataclass(frozen=True)
class Payload:
    """A held object as a box centred on a robot frame (e.g. the grasp frame between the pads)."""

    body: str
    half_extents: tuple[float, float, float]


def add_payload(spec: mujoco.MjSpec, payload: Payload) -> None:
    """Attach the payload box to its body, collisions disabled until the planner enables them."""
    body = spec.body(payload.body)
    if body is None:
        raise PlanningError(f"payload body {payload.body!r} is not in the robot model")
    body.add_geom(
        name=PAYLOAD_GEOM,
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=list(payload.half_extents),
        contype=0,
        conaffinity=0,
        group=3,
        mass=0.0,
        density=0.0,
    )


def build_planning_model(
    robot_description: str | Path,
    obstacles: Sequence[BoxObstacle] = (),
    payload: Payload | None = None,
) -> mujoco.MjModel:
    """Compile a URDF or MJCF robot file with MuJoCo's own loader; add obstacles and a payload."""
    path = Path(robot_description)
    if not path.is_file():
        raise PlanningError(f"robot description {str(path)!r} does not exist")
    try:
        spec = mujoco.MjSpec.from_file(str(path))
        add_obstacles(spec, obstacles)
        if payload is not None:
            add_payload(spec, payload)
        model = spec.compile()
    except ValueError as exc:
        raise PlanningError(f"cannot build a planning model from {str(path)!r}: {exc}") from exc
    return model
