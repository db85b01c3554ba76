"""A small production line: two Niryo One arms (two copies of one URDF, /arm_in and
/arm_out) and a shuttle conveyor (/conveyor), each robot in its own namespace and on its
own connection, driven only through the standard controller actions by in-process nodes.
`run_line` runs it headless; `simbridge demo line` is its command line."""

from __future__ import annotations

from simbridge.apps.line.cells import ArmCell, ConveyorCell, RobotNode, RobotTally
from simbridge.apps.line.result import DELIVERY_TOLERANCE_M, LineResult
from simbridge.apps.line.runner import main, run_line
from simbridge.apps.line.scene import ARMS, CONVEYOR, SCENE_PATH, line_scene
from simbridge.apps.line.supervisor import LineSupervisor
from simbridge.apps.line.task import MAX_PARTS, LineTask, PartStart
from simbridge.apps.line.view import AGAIN_LABEL, LineView

__all__ = [
    "AGAIN_LABEL",
    "ARMS",
    "CONVEYOR",
    "DELIVERY_TOLERANCE_M",
    "MAX_PARTS",
    "SCENE_PATH",
    "ArmCell",
    "ConveyorCell",
    "LineResult",
    "LineSupervisor",
    "LineTask",
    "LineView",
    "PartStart",
    "RobotNode",
    "RobotTally",
    "line_scene",
    "main",
    "run_line",
]
