"""Pick and place, as in Unity's Robotics Hub tutorial: a Niryo One planned over ROS, in MuJoCo.

A planner node serves niryo_moveit/MoverService on /niryo_moveit (MoverPlanner); the
simulation side calls it through the connector, follows the four trajectories on the
joint drives and grips the cube by contact. `run_pick_and_place` runs the whole chain.
"""

from __future__ import annotations

from simbridge.apps.pick_and_place.demo import AGAIN_LABEL, PickAndPlaceDemo
from simbridge.apps.pick_and_place.planner_node import (
    PLANNER_SERVICE,
    SERVICE_TYPE,
    LocalPlannerNode,
    MoverServiceHandler,
    planner_for_scene,
)
from simbridge.apps.pick_and_place.result import PhaseTiming, PickAndPlaceResult
from simbridge.apps.pick_and_place.runner import BACKENDS, main, run_pick_and_place
from simbridge.apps.pick_and_place.scene import SCENE_PATH, build_world, planning_obstacles
from simbridge.apps.pick_and_place.sim_side import ExecutionOptions, PickAndPlaceSim
from simbridge.apps.pick_and_place.task import PickAndPlaceTask

__all__ = [
    "AGAIN_LABEL",
    "BACKENDS",
    "PLANNER_SERVICE",
    "SCENE_PATH",
    "SERVICE_TYPE",
    "ExecutionOptions",
    "LocalPlannerNode",
    "MoverServiceHandler",
    "PhaseTiming",
    "PickAndPlaceDemo",
    "PickAndPlaceResult",
    "PickAndPlaceSim",
    "PickAndPlaceTask",
    "build_world",
    "main",
    "planner_for_scene",
    "planning_obstacles",
    "run_pick_and_place",
]
