"""The pick-and-place world: the shipped scene YAML, the task's cube pose, grasp-ready contacts."""

from __future__ import annotations

import dataclasses
import xml.etree.ElementTree as ET
from collections.abc import Callable
from pathlib import Path

import numpy as np

from simbridge.apps.pick_and_place.task import PickAndPlaceTask
from simbridge.errors import AppError
from simbridge.planning import BoxObstacle, matrix_to_quaternion
from simbridge.sim import Scene, World, load_scene
from simbridge.sim.scene import ObjectSpec, Origin
from simbridge.sim.urdf.document import MjcfDocument, fmt

__all__ = [
    "CUBE",
    "FINGER_GEOMS",
    "ROBOT",
    "SCENE_PATH",
    "TARGET_MARKER",
    "build_world",
    "planning_obstacles",
    "task_scene",
]

SCENE_PATH = Path(__file__).with_name("scene.yaml")
"""The shipped scene: Niryo One on a table (table top z = 0), a 5 cm cube."""
ROBOT = "niryo_one"
CUBE = "cube"
TARGET_MARKER = "place_target"
FINGER_GEOMS = ("left_finger_link/collision/0", "right_finger_link/collision/0")

# Contact settings that let two narrow finger pads hold a cube: stiff contacts (the default
# 20 ms time constant lets the squeezed cube yaw and creep out of the pads), torsional
# friction, an elliptic friction cone, and a stiff finger mimic coupling.
_STIFF_SOLREF = (0.004, 1.0)
_STIFF_SOLIMP = (0.95, 0.99, 0.001, 0.5, 2.0)
_MIMIC_SOLREF = (0.005, 1.0)


def task_scene(task: PickAndPlaceTask, path: Path = SCENE_PATH) -> Scene:
    """The scene at ``path`` with its cube moved to the task's start pose."""
    scene = load_scene(path)
    objects = list(scene.objects)
    for index, obj in enumerate(objects):
        if obj.name == CUBE:
            pose = Origin(task.cube_center, (0.0, 0.0, task.cube_yaw))
            size = (task.cube_size,) * 3
            objects[index] = dataclasses.replace(obj, pose=pose, size=size)
            break
    else:
        names = ", ".join(o.name for o in objects) or "none"
        raise AppError(f"scene {path} has no dynamic object {CUBE!r} (objects: {names})")
    return dataclasses.replace(scene, objects=tuple(objects))


def _geom(doc: MjcfDocument, name: str) -> ET.Element:
    for elem in doc.worldbody.iter("geom"):
        if elem.get("name") == name:
            return elem
    raise AppError(f"the scene has no geom {name!r} (the gripper or cube is missing)")


def _grasp_contacts(doc: MjcfDocument) -> None:
    """Stiff, torsion-resisting contacts between the finger pads and the cube."""
    doc.option.attrib.update(cone="elliptic", impratio="10")
    for name in (CUBE, *FINGER_GEOMS):
        _geom(doc, name).attrib.update(
            condim="4", solref=fmt(_STIFF_SOLREF), solimp=fmt(_STIFF_SOLIMP)
        )
    for mimic in doc.section("equality").iter("joint"):
        mimic.set("solref", fmt(_MIMIC_SOLREF))


def _target_marker(task: PickAndPlaceTask) -> Callable[[MjcfDocument], None]:
    """A flat, non-colliding square drawn on the table where the cube must go."""

    def add(doc: MjcfDocument) -> None:
        x, y, _ = task.target_center
        half = task.cube_size / 2 + 0.005
        yaw = task.target_yaw
        ET.SubElement(
            doc.worldbody,
            "geom",
            name=TARGET_MARKER,
            type="box",
            size=fmt((half, half, 0.0005)),
            pos=fmt((x, y, 0.0005)),
            quat=fmt((np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2))),
            rgba="0.2 0.8 0.3 0.6",
            contype="0",
            conaffinity="0",
            group="1",
        )

    return add


def build_world(task: PickAndPlaceTask, path: Path = SCENE_PATH) -> World:
    """Compile the scene for ``task``: cube at its start, target marked, grasp contacts tuned."""
    return World.from_scene(task_scene(task, path), [_grasp_contacts, _target_marker(task)])


def _box_obstacle(obj: ObjectSpec) -> BoxObstacle:
    transform = obj.pose.transform
    x, y, z = (float(v) for v in transform.translation)
    hx, hy, hz = (s / 2 for s in obj.size)
    qx, qy, qz, qw = (float(v) for v in matrix_to_quaternion(transform.rotation))
    return BoxObstacle(obj.name, (x, y, z), (hx, hy, hz), (qx, qy, qz, qw))


def planning_obstacles(scene: Scene) -> list[BoxObstacle]:
    """The scene's static boxes (the table) as planner obstacles, in the robot's base frame.

    Moving objects (the cube) are left out, as the tutorial's MoveIt scene leaves out its
    target. The robot's base must sit at the world origin, unrotated (as in the shipped scene).
    """
    for robot in scene.robots:
        if robot.base.xyz != (0.0, 0.0, 0.0) or robot.base.rpy != (0.0, 0.0, 0.0):
            raise AppError(
                f"robot {robot.name!r} must sit at the world origin for planning, "
                f"got xyz={robot.base.xyz} rpy={robot.base.rpy}"
            )
    return [_box_obstacle(o) for o in scene.objects if o.shape == "box" and not o.dynamic]
