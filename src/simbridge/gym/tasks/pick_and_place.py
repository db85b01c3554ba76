"""PickAndPlace-v0: the pick-and-place demo's task, cube to target, by a physics grasp."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Mapping, Sequence
from importlib import resources
from pathlib import Path

import mujoco
import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray

from simbridge.errors import GymError
from simbridge.gym.actions import CombinedAction, EndEffectorDelta, GripperCommand
from simbridge.gym.env import SceneEnv, look_at
from simbridge.gym.sensors import CameraImage, SensorObservation
from simbridge.gym.task import Task
from simbridge.gym.tasks.reach import ARM_JOINTS, view_camera
from simbridge.planning import quaternion_to_matrix, top_down_orientation
from simbridge.sim.urdf.document import MjcfDocument, fmt
from simbridge.sim.world import ModelExtension, World

__all__ = ["PICK_AND_PLACE_SCENE", "PickAndPlaceEnvTask", "make_pick_and_place"]

PICK_AND_PLACE_SCENE = Path(
    str(resources.files("simbridge") / "apps" / "pick_and_place" / "scene.yaml")
)
"""The demo's scene: a Niryo One on a table (top at z = 0) and a 5 cm cube."""
GRIPPER_JOINT = "left_finger_joint"
FINGER_GEOMS = ("left_finger_link/collision/0", "right_finger_link/collision/0")
TARGET_MARKER = "target_marker"
TOP_DOWN = quaternion_to_matrix(top_down_orientation(0.0))
"""The tool orientation held throughout: approach axis straight down."""


def grasp_contacts(doc: MjcfDocument) -> None:
    """Stiff, torsion-resisting finger-cube contacts (elliptic cones, condim 4) and a stiff
    finger coupling: the contact settings the demo grips with."""
    doc.option.attrib.update(cone="elliptic", impratio="10")
    for geom in doc.worldbody.iter("geom"):
        if geom.get("name") in ("cube", *FINGER_GEOMS):
            geom.attrib.update(condim="4", solref="0.004 1", solimp="0.95 0.99 0.001 0.5 2")
    for mimic in doc.section("equality").iter("joint"):
        mimic.set("solref", "0.005 1")


def _target_marker(doc: MjcfDocument) -> None:
    body = ET.SubElement(doc.worldbody, "body", name=TARGET_MARKER, mocap="true")
    ET.SubElement(
        body,
        "geom",
        type="box",
        size=fmt((0.03, 0.03, 0.0005)),
        rgba="0.2 0.8 0.3 0.6",
        contype="0",
        conaffinity="0",
        group="1",
    )


def _ring_point(rng: np.random.Generator) -> NDArray[np.float64]:
    """A table point 0.17-0.28 m from the base axis within +-60 degrees of +x."""
    radius = rng.uniform(0.17, 0.28)
    bearing = rng.uniform(-math.pi / 3, math.pi / 3)
    return np.array([radius * math.cos(bearing), radius * math.sin(bearing)])


class PickAndPlaceEnvTask(Task):
    """Move the cube (by grasping it: nothing else moves it) to the target on the table.

    Reset: the gripper open, pointing down 0.12 m above the table at (0.2, 0), the cube
    (yaw 0) and the target drawn on a ring 0.17-0.28 m from the base, 0.1 m apart or
    more. Reward: -(grasp point to cube) - 2 (cube to target), in m. Success (and
    termination): the cube's centre within `tolerance` of the target centre (set down
    there) with the fingers opened wider than the cube (let go). Observation adds
    "ee_pos" (grasp point), "cube_pos" and "cube_quat" (w, x, y, z).
    """

    goal_space = spaces.Box(-1.0, 1.0, (3,), np.float32)

    def __init__(self, tolerance: float = 0.02, cube: str = "cube") -> None:
        self.tolerance, self.cube = tolerance, cube
        self.arm = EndEffectorDelta("tool_link", ARM_JOINTS, orientation=TOP_DOWN)
        self._grasp = -1
        self._cube_body = -1
        self._cube_qpos = -1
        self._cube_half = 0.025
        self._mocap = -1
        self._finger_qpos = -1

    def extensions(self) -> Sequence[ModelExtension]:
        """Grasp contacts and the target marker."""
        return (grasp_contacts, _target_marker)

    def bind(self, world: World) -> None:
        """Find the grasp point, the cube's free joint and the marker."""
        self.arm.bind(world)
        model = world.model
        self._grasp = int(model.body("grasp_link").id)
        body = model.body(self.cube)
        joint = int(body.jntadr[0])
        if joint < 0 or model.jnt_type[joint] != mujoco.mjtJoint.mjJNT_FREE:
            raise GymError(f"PickAndPlace: object {self.cube!r} must be dynamic (a free body)")
        self._cube_body, self._cube_qpos = int(body.id), int(model.jnt_qposadr[joint])
        geom = int(body.geomadr[0])
        self._cube_half = float(model.geom_size[geom][2])
        self._mocap = int(model.body_mocapid[model.body(TARGET_MARKER).id])
        self._finger_qpos = int(model.joint(GRIPPER_JOINT).qposadr[0])

    def reset(self, world: World, rng: np.random.Generator) -> NDArray[np.float64]:
        """Arm to the ready pose, cube and target on the ring."""
        if not self.arm.solve(world, np.array([0.2, 0.0, 0.17])):
            raise GymError("PickAndPlace: the ready pose is out of reach")
        cube = _ring_point(rng)
        target = _ring_point(rng)
        while np.linalg.norm(target - cube) < 0.1:
            target = _ring_point(rng)
        adr = self._cube_qpos
        world.data.qpos[adr : adr + 3] = (*cube, self._cube_half)
        world.data.qpos[adr + 3 : adr + 7] = (1.0, 0.0, 0.0, 0.0)
        goal = np.array([*target, self._cube_half])
        world.data.mocap_pos[self._mocap] = (target[0], target[1], 0.0005)
        mujoco.mj_forward(world.model, world.data)
        return goal

    def observation_spaces(self) -> Mapping[str, spaces.Box]:
        """Grasp point, cube position and orientation."""
        return {
            "ee_pos": spaces.Box(-2.0, 2.0, (3,), np.float32),
            "cube_pos": spaces.Box(-2.0, 2.0, (3,), np.float32),
            "cube_quat": spaces.Box(-1.0, 1.0, (4,), np.float32),
        }

    def observe(self, world: World, goal: NDArray[np.float64]) -> dict[str, NDArray[np.float32]]:
        """Grasp point, cube position and orientation (w, x, y, z)."""
        data = world.data
        quat = np.empty(4)
        mujoco.mju_mat2Quat(quat, data.xmat[self._cube_body])
        return {
            "ee_pos": data.xpos[self._grasp].astype(np.float32),
            "cube_pos": data.xpos[self._cube_body].astype(np.float32),
            "cube_quat": np.clip(quat, -1.0, 1.0).astype(np.float32),
        }

    def reward(self, world: World, goal: NDArray[np.float64], action: NDArray[np.float32]) -> float:
        """Dense shaping: reach the cube, bring it to the target."""
        data = world.data
        cube = data.xpos[self._cube_body]
        return -float(np.linalg.norm(data.xpos[self._grasp] - cube)) - 2 * float(
            np.linalg.norm(cube - goal)
        )

    def success(self, world: World, goal: NDArray[np.float64]) -> bool:
        """The cube is on the target and the fingers have let go of it."""
        released = float(world.data.qpos[self._finger_qpos]) > self._cube_half + 0.004
        at_target = float(np.linalg.norm(world.data.xpos[self._cube_body] - goal)) < self.tolerance
        return released and at_target


def make_pick_and_place(
    *,
    frame_skip: int = 10,
    image_size: tuple[int, int] | None = None,
    render_mode: str | None = None,
    world: World | None = None,
) -> SceneEnv:
    """The PickAndPlace-v0 environment (`gymnasium.make("simbridge/PickAndPlace-v0")`).

    Action: Box(4): the grasp point's step in m (+-0.02 per axis, world frame; the tool
    keeps pointing down) and the gripper in [-1, 1] (-1 closed, +1 open). `image_size`
    (height, width) adds an "image" observation from a fixed camera.
    """
    task = PickAndPlaceEnvTask()
    sensors: list[SensorObservation] = []
    if image_size is not None:
        height, width = image_size
        camera = view_camera((0.6, -0.45, 0.45), (0.2, 0.0, 0.0), width, height)
        sensors.append(CameraImage(camera))
    return SceneEnv(
        PICK_AND_PLACE_SCENE,
        task,
        CombinedAction([task.arm, GripperCommand(GRIPPER_JOINT)]),
        frame_skip=frame_skip,
        sensors=sensors,
        render_mode=render_mode,
        render_camera=look_at((0.6, -0.45, 0.45), (0.2, 0.0, 0.0)),
        world=world,
    )
