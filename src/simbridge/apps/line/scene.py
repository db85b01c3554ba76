"""The line world: the shipped scene YAML plus the run's parts, output markers and
grasp-ready contacts for both grippers."""

from __future__ import annotations

import dataclasses
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from simbridge.apps.line.task import PART_SIZE, LineTask
from simbridge.errors import AppError
from simbridge.sim import Scene, load_scene
from simbridge.sim.scene import ObjectSpec, Origin
from simbridge.sim.urdf.document import MjcfDocument, fmt
from simbridge.sim.world import ModelExtension

__all__ = ["ARMS", "CONVEYOR", "SCENE_PATH", "grasp_contacts", "line_scene", "part_name"]

SCENE_PATH = Path(__file__).with_name("scene.yaml")
"""The shipped scene: two Niryo One arms and a shuttle conveyor on a table."""
ARMS = ("arm_in", "arm_out")
CONVEYOR = "conveyor"
_FINGER_GEOMS = ("left_finger_link/collision/0", "right_finger_link/collision/0")
_PART_COLOURS = ((0.9, 0.25, 0.2), (0.95, 0.7, 0.15), (0.3, 0.75, 0.3), (0.6, 0.3, 0.8))

# As in pick_and_place: stiff, torsion-resisting contacts between finger pads and parts, an
# elliptic friction cone and a stiff finger mimic coupling, so narrow pads hold a cube.
_STIFF_SOLREF = (0.004, 1.0)
_STIFF_SOLIMP = (0.95, 0.99, 0.001, 0.5, 2.0)
_MIMIC_SOLREF = (0.005, 1.0)


def part_name(index: int) -> str:
    """The MuJoCo body (and geom) name of part ``index``."""
    return f"part_{index}"


def line_scene(task: LineTask, path: Path = SCENE_PATH) -> Scene:
    """The scene at ``path`` with the task's parts added at their start poses."""
    scene = load_scene(path)
    names = {str(robot.name) for robot in scene.robots}
    if not {*ARMS, CONVEYOR} <= names:
        raise AppError(
            f"scene {path} needs robots {', '.join((*ARMS, CONVEYOR))}, has {sorted(names)}"
        )
    parts = tuple(
        ObjectSpec(
            name=part_name(index),
            shape="box",
            size=(PART_SIZE,) * 3,
            pose=Origin((part.x, part.y, PART_SIZE / 2), (0.0, 0.0, part.yaw)),
            dynamic=True,
            mass=0.1,
            friction=(1.2, 0.01, 0.0001),
            rgba=(*_PART_COLOURS[index % len(_PART_COLOURS)], 1.0),
        )
        for index, part in enumerate(task.parts)
    )
    return dataclasses.replace(scene, objects=(*scene.objects, *parts))


def grasp_contacts(task: LineTask, arms: tuple[str, ...] = ARMS) -> list[ModelExtension]:
    """MJCF edits for ``World.from_scene``: grasp contacts (for the grippers of ``arms``)
    and the output slot markers."""

    def contacts(doc: MjcfDocument) -> None:
        doc.option.attrib.update(cone="elliptic", impratio="10")
        geoms = {elem.get("name"): elem for elem in doc.worldbody.iter("geom")}
        wanted = [part_name(i) for i in range(len(task.parts))]
        wanted += [f"{arm}/{finger}" for arm in arms for finger in _FINGER_GEOMS]
        for name in wanted:
            if name not in geoms:
                raise AppError(f"the line scene has no geom {name!r} (a gripper or part)")
            geoms[name].attrib.update(
                condim="4", solref=fmt(_STIFF_SOLREF), solimp=fmt(_STIFF_SOLIMP)
            )
        for mimic in doc.section("equality").iter("joint"):
            mimic.set("solref", fmt(_MIMIC_SOLREF))

    def markers(doc: MjcfDocument) -> None:
        half = PART_SIZE / 2 + 0.005
        for index in range(len(task.parts)):
            x, y, _ = task.target(index)
            ET.SubElement(
                doc.worldbody,
                "geom",
                name=f"output_slot_{index}",
                type="box",
                size=fmt((half, half, 0.0005)),
                pos=fmt((x, y, 0.0005)),
                quat=fmt((1.0, 0.0, 0.0, 0.0)),
                rgba=fmt((*np.array(_PART_COLOURS[index % len(_PART_COLOURS)]) * 0.8, 0.5)),
                contype="0",
                conaffinity="0",
                group="1",
            )

    return [contacts, markers]
