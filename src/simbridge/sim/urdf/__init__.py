"""URDF (and xacro) import: parse, validate, compute kinematics and build MuJoCo models."""

from __future__ import annotations

from simbridge.sim.urdf.document import MjcfDocument
from simbridge.sim.urdf.inertia import InertiaPolicy, inertial_from_collisions, inertial_problem
from simbridge.sim.urdf.kinematics import JointValue, forward_kinematics
from simbridge.sim.urdf.loader import expand_xacro, load_urdf, load_urdf_string
from simbridge.sim.urdf.meshes import MeshCache
from simbridge.sim.urdf.mjcf import (
    COLLISION_GROUP,
    VISUAL_GROUP,
    JointMapping,
    MjcfOptions,
    RobotMjcf,
    UrdfWarning,
    add_robot,
    robot_to_mjcf,
)
from simbridge.sim.urdf.parser import parse_urdf
from simbridge.sim.urdf.report import (
    check_report,
    fk_poses,
    parse_joint_assignments,
    parse_xacro_args,
    urdf_check,
    urdf_fk,
)
from simbridge.sim.urdf.resources import ResourceResolver
from simbridge.sim.urdf.robot import (
    Box,
    Collision,
    Cylinder,
    Geometry,
    Inertial,
    Joint,
    JointDynamics,
    JointLimit,
    JointType,
    Link,
    Material,
    Mesh,
    Mimic,
    Origin,
    Robot,
    Sphere,
    Visual,
)
from simbridge.sim.urdf.transforms import Transform

__all__ = [
    "COLLISION_GROUP",
    "VISUAL_GROUP",
    "Box",
    "Collision",
    "Cylinder",
    "Geometry",
    "InertiaPolicy",
    "Inertial",
    "Joint",
    "JointDynamics",
    "JointLimit",
    "JointMapping",
    "JointType",
    "JointValue",
    "Link",
    "Material",
    "Mesh",
    "MeshCache",
    "Mimic",
    "MjcfDocument",
    "MjcfOptions",
    "Origin",
    "ResourceResolver",
    "Robot",
    "RobotMjcf",
    "Sphere",
    "Transform",
    "UrdfWarning",
    "Visual",
    "add_robot",
    "check_report",
    "expand_xacro",
    "fk_poses",
    "forward_kinematics",
    "inertial_from_collisions",
    "inertial_problem",
    "load_urdf",
    "load_urdf_string",
    "parse_joint_assignments",
    "parse_urdf",
    "parse_xacro_args",
    "robot_to_mjcf",
    "urdf_check",
    "urdf_fk",
]
