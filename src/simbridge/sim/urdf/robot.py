"""The parsed URDF robot: plain frozen dataclasses, independent of MuJoCo."""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum
from pathlib import Path

import numpy as np

from simbridge.sim.urdf.transforms import Transform, Vec3

__all__ = [
    "Box",
    "Collision",
    "Cylinder",
    "Geometry",
    "Inertial",
    "Joint",
    "JointDynamics",
    "JointLimit",
    "JointType",
    "Link",
    "Material",
    "Mesh",
    "Mimic",
    "Origin",
    "Robot",
    "Sphere",
    "Visual",
]


@dataclass(frozen=True)
class Origin:
    """A URDF `<origin>`: translation in metres and fixed-axis roll/pitch/yaw in radians; also
    a scene's placement of a robot's base or an object (its `pose:`)."""

    xyz: Vec3 = (0.0, 0.0, 0.0)
    rpy: Vec3 = (0.0, 0.0, 0.0)

    @property
    def transform(self) -> Transform:
        """The rigid transform this origin describes."""
        return Transform.from_xyz_rpy(self.xyz, self.rpy)


@dataclass(frozen=True)
class Box:
    """A box by its full edge lengths."""

    size: Vec3


@dataclass(frozen=True)
class Cylinder:
    """A cylinder along the local Z axis, centred on the origin."""

    radius: float
    length: float


@dataclass(frozen=True)
class Sphere:
    """A sphere centred on the origin."""

    radius: float


@dataclass(frozen=True)
class Mesh:
    """A mesh file as written in the URDF, its resolved path (if found) and scale."""

    filename: str
    scale: Vec3 = (1.0, 1.0, 1.0)
    path: Path | None = None


Geometry = Box | Cylinder | Sphere | Mesh


@dataclass(frozen=True)
class Material:
    """A named colour (RGBA in 0..1) and optional texture file."""

    name: str
    rgba: tuple[float, float, float, float] | None = None
    texture: str | None = None


@dataclass(frozen=True)
class Visual:
    """Geometry drawn but never collided with."""

    geometry: Geometry
    origin: Origin = Origin()
    material: Material | None = None
    name: str | None = None


@dataclass(frozen=True)
class Collision:
    """Geometry used for contacts (and for inertia when the URDF's is unusable)."""

    geometry: Geometry
    origin: Origin = Origin()
    name: str | None = None


@dataclass(frozen=True)
class Inertial:
    """Mass (kg), centre of mass frame and the 3x3 inertia tensor about it (kg m^2)."""

    mass: float
    origin: Origin = Origin()
    ixx: float = 0.0
    ixy: float = 0.0
    ixz: float = 0.0
    iyy: float = 0.0
    iyz: float = 0.0
    izz: float = 0.0

    @property
    def tensor(self) -> np.ndarray:
        """The symmetric inertia matrix in the inertial origin's frame."""
        return np.array(
            [
                [self.ixx, self.ixy, self.ixz],
                [self.ixy, self.iyy, self.iyz],
                [self.ixz, self.iyz, self.izz],
            ],
            dtype=np.float64,
        )


@dataclass(frozen=True)
class Link:
    """A rigid body; the frame TF publishes under this name."""

    name: str
    inertial: Inertial | None = None
    visuals: tuple[Visual, ...] = ()
    collisions: tuple[Collision, ...] = ()


class JointType(Enum):
    """The URDF joint types."""

    REVOLUTE = "revolute"
    CONTINUOUS = "continuous"
    PRISMATIC = "prismatic"
    FIXED = "fixed"
    FLOATING = "floating"
    PLANAR = "planar"

    @property
    def is_single_dof(self) -> bool:
        """Whether the joint has exactly one scalar position (what joint_states carries)."""
        return self in (JointType.REVOLUTE, JointType.CONTINUOUS, JointType.PRISMATIC)


@dataclass(frozen=True)
class JointLimit:
    """Position range (rad or m), maximum effort (N or N m) and velocity."""

    lower: float = 0.0
    upper: float = 0.0
    effort: float = 0.0
    velocity: float = 0.0


@dataclass(frozen=True)
class JointDynamics:
    """Viscous damping and Coulomb friction of a joint."""

    damping: float = 0.0
    friction: float = 0.0


@dataclass(frozen=True)
class Mimic:
    """This joint follows `joint`: q = multiplier * q_joint + offset."""

    joint: str
    multiplier: float = 1.0
    offset: float = 0.0


@dataclass(frozen=True)
class Joint:
    """A joint connecting `parent` to `child`; `origin` is the child frame in the parent's."""

    name: str
    type: JointType
    parent: str
    child: str
    origin: Origin = Origin()
    axis: Vec3 = (1.0, 0.0, 0.0)
    limit: JointLimit | None = None
    dynamics: JointDynamics = JointDynamics()
    mimic: Mimic | None = None

    @property
    def limited(self) -> bool:
        """Whether the position range applies: revolute and prismatic joints with a non-empty
        range (an empty one, e.g. a `<limit>` without lower/upper, is simulated unlimited)."""
        return (
            self.limit is not None
            and self.type in (JointType.REVOLUTE, JointType.PRISMATIC)
            and self.limit.lower < self.limit.upper
        )


@dataclass(frozen=True)
class Robot:
    """A validated kinematic tree: one root link, every other link has one parent joint."""

    name: str
    links: dict[str, Link]
    joints: dict[str, Joint]
    root: str
    materials: dict[str, Material] = field(default_factory=dict)
    source: Path | None = None
    warnings: tuple[str, ...] = ()
    xml: str = field(default="", repr=False, compare=False)
    """The URDF text parsed (xacro already expanded): what `robot_description` starts from."""

    def child_joints(self, link: str) -> list[Joint]:
        """Joints whose parent is `link`, in document order."""
        return [j for j in self.joints.values() if j.parent == link]

    def parent_joint(self, link: str) -> Joint | None:
        """The joint whose child is `link` (None for the root)."""
        for joint in self.joints.values():
            if joint.child == link:
                return joint
        return None

    def links_depth_first(self) -> list[str]:
        """Link names from the root, parents before children, in document order."""
        order: list[str] = []
        stack = [self.root]
        while stack:
            name = stack.pop()
            order.append(name)
            stack.extend(reversed([j.child for j in self.child_joints(name)]))
        return order

    @property
    def movable_joints(self) -> list[Joint]:
        """Joints with one scalar position, in document order (the joint_states set)."""
        return [j for j in self.joints.values() if j.type.is_single_dof]
