"""Shared planning fixtures: the shipped Niryo One on a table, loaded with MuJoCo's URDF loader."""

from __future__ import annotations

import pytest

from simbridge.assets import robot_urdf
from simbridge.planning import (
    DEFAULT_PAYLOAD,
    ArmKinematics,
    BoxObstacle,
    MoverPlanner,
    build_planning_model,
    niryo_one_arm,
)

# The table top is the robot's mounting plane (z = 0 in base_link).
TABLE = BoxObstacle("table", center=(0.15, 0.0, -0.025), half_extents=(0.45, 0.6, 0.025))


@pytest.fixture(scope="session")
def kinematics() -> ArmKinematics:
    model = build_planning_model(robot_urdf("niryo_one"), [TABLE], DEFAULT_PAYLOAD)
    return ArmKinematics(model, niryo_one_arm())


@pytest.fixture(scope="session")
def mover() -> MoverPlanner:
    return MoverPlanner.niryo_one([TABLE])
