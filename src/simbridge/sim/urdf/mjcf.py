"""Turn a `Robot` into MJCF bodies: one body per link (same name), joints, geoms, mimic equalities.

Built by hand rather than with MuJoCo's URDF loader, which fuses fixed links away and
drops joint damping; here fixed-joint links stay bodies so TF frames match the URDF.
"""

from __future__ import annotations

import warnings
import xml.etree.ElementTree as ET
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from simbridge.errors import UrdfError
from simbridge.sim.urdf.diagnostics import UrdfWarning
from simbridge.sim.urdf.document import MjcfDocument, fmt
from simbridge.sim.urdf.inertia import InertiaPolicy, resolve_inertial
from simbridge.sim.urdf.kinematics import plane_basis
from simbridge.sim.urdf.meshes import MeshCache, MeshPart
from simbridge.sim.urdf.robot import (
    Box,
    Cylinder,
    Geometry,
    Inertial,
    Joint,
    JointType,
    Mesh,
    Origin,
    Robot,
    Sphere,
)
from simbridge.sim.urdf.transforms import Transform

__all__ = [
    "COLLISION_GROUP",
    "VISUAL_GROUP",
    "JointMapping",
    "MjcfOptions",
    "RobotMjcf",
    "UrdfWarning",
    "add_robot",
    "robot_to_mjcf",
]

VISUAL_GROUP = 1
"""MuJoCo geom group of visual geometry (drawn, never collides)."""
COLLISION_GROUP = 3
"""MuJoCo geom group of collision geometry (hidden by default in the viewer)."""


@dataclass(frozen=True)
class MjcfOptions:
    """How a robot enters a MuJoCo model.

    `prefix` is prepended to every body, joint and geom name (for two copies of a robot);
    `self_collision` lets non-adjacent links of the robot collide with each other.
    """

    prefix: str = ""
    base: Transform = field(default_factory=Transform.identity)
    fixed_base: bool = True
    self_collision: bool = False
    armature: float = 0.0
    inertia: InertiaPolicy = field(default_factory=InertiaPolicy)
    collision_rgba: tuple[float, float, float, float] = (0.6, 0.3, 0.3, 0.4)
    default_rgba: tuple[float, float, float, float] = (0.7, 0.7, 0.7, 1.0)


@dataclass(frozen=True)
class JointMapping:
    """A URDF joint and its MuJoCo joint(s): none for fixed, 3 for planar, 4 for floating."""

    joint: Joint
    mj_joints: tuple[str, ...]


@dataclass(frozen=True)
class RobotMjcf:
    """What `add_robot` put into a document."""

    robot: Robot
    options: MjcfOptions
    joints: dict[str, JointMapping]
    warnings: tuple[str, ...]
    inertials: dict[str, Inertial | None] = field(default_factory=dict)
    """The inertial each link was simulated with (after replacing unusable ones)."""

    def body_name(self, link: str) -> str:
        """The MuJoCo body name of URDF link `link`."""
        return self.options.prefix + link

    def joint_name(self, joint: str) -> str:
        """The MuJoCo joint name of a 1-DoF URDF joint."""
        return self.options.prefix + joint


def _origin_attrs(origin: Origin | Transform) -> dict[str, Any]:
    tf = origin.transform if isinstance(origin, Origin) else origin
    return {"pos": fmt(tf.translation), "quat": fmt(tf.quat_wxyz)}


class _Builder:
    def __init__(self, doc: MjcfDocument, robot: Robot, options: MjcfOptions, meshes: MeshCache):
        self.doc, self.robot, self.opt, self.meshes = doc, robot, options, meshes
        self.warnings: list[str] = list(robot.warnings)
        self.robot_where = f"{robot.source}: " if robot.source is not None else ""
        self.mappings: dict[str, JointMapping] = {}
        self.inertials: dict[str, Inertial | None] = {}
        existing = set(doc.body_names())
        clashes = [options.prefix + n for n in robot.links if options.prefix + n in existing]
        if clashes:
            raise UrdfError(
                f"robot '{robot.name}': bodies {', '.join(clashes)} already exist in the model "
                "(give the robot a name prefix)"
            )

    def warn(self, text: str) -> None:
        """Record and emit a warning, prefixed with the URDF file."""
        text = self.robot_where + text
        self.warnings.append(text)
        warnings.warn(text, UrdfWarning, stacklevel=3)

    def geom(
        self, body: ET.Element, name: str, geometry: Geometry, origin: Transform
    ) -> ET.Element:
        attrs = {"name": name, **_origin_attrs(origin)}
        if isinstance(geometry, Box):
            attrs.update(type="box", size=fmt(np.array(geometry.size) / 2.0))
        elif isinstance(geometry, Cylinder):
            attrs.update(type="cylinder", size=fmt((geometry.radius, geometry.length / 2.0)))
        elif isinstance(geometry, Sphere):
            attrs.update(type="sphere", size=fmt(geometry.radius))
        else:
            attrs.update(type="mesh", mesh=self.mesh_asset(name, geometry))
        return ET.SubElement(body, "geom", attrs)

    def visual_geoms(
        self, body: ET.Element, name: str, geometry: Geometry, origin: Transform
    ) -> list[tuple[ET.Element, MeshPart | None]]:
        """The geoms drawing one visual: one per colour/texture part of a mesh file."""
        if not isinstance(geometry, Mesh):
            return [(self.geom(body, name, geometry, origin), None)]
        assert geometry.path is not None
        out: list[tuple[ET.Element, MeshPart | None]] = []
        parts = self.meshes.visual_parts(geometry.path, f"{self.robot_where}{name}")
        for k, part in enumerate(parts):
            part_name = name if k == 0 else f"{name}.{k}"
            ET.SubElement(
                self.doc.asset,
                "mesh",
                name=part_name,
                file=str(part.file),
                scale=fmt(geometry.scale),
                inertia="shell",
            )
            attrs = {"name": part_name, "type": "mesh", "mesh": part_name, **_origin_attrs(origin)}
            out.append((ET.SubElement(body, "geom", attrs), part))
        return out

    def collision_shape(
        self, name: str, geometry: Geometry, pose: Transform
    ) -> tuple[Geometry, Transform]:
        """The geometry to collide with: flat meshes become thin boxes (with a warning)."""
        if not isinstance(geometry, Mesh) or geometry.path is None:
            return geometry, pose
        flat = self.meshes.flat_box(geometry.path, geometry.scale)
        if flat is None:
            return geometry, pose
        centre, size = flat
        warning = f"{name}: mesh '{geometry.filename}' is flat; colliding with a thin box instead"
        self.warn(warning)
        return Box(size), pose @ Transform(np.eye(3), np.array(centre))

    def mesh_asset(self, name: str, mesh: Mesh) -> str:
        if mesh.path is None:
            # the loader's warning says where it looked and how to add a folder
            why = next((w for w in self.robot.warnings if f"'{mesh.filename}'" in w), None)
            raise UrdfError(f"{name}: mesh '{mesh.filename}' was not found: {why or 'no resolver'}")
        file = self.meshes.mujoco_file(mesh.path, f"{self.robot_where}{name}")
        ET.SubElement(
            self.doc.asset,
            "mesh",
            name=name,
            file=str(file),
            scale=fmt(mesh.scale),
            inertia="shell",
        )
        return name

    def link_body(
        self, parent: ET.Element, link_name: str, joint: Joint | None, offset: Transform
    ) -> ET.Element:
        """Add the body of `link_name` under `parent`; `offset` premultiplies its pose."""
        p = self.opt.prefix
        link = self.robot.links[link_name]
        if joint is None and p + link_name == "world":
            # A URDF root named "world" is MuJoCo's world body itself.
            if not self.opt.fixed_base:
                raise UrdfError(f"robot '{self.robot.name}': root link 'world' cannot float")
            self.link_geoms(parent, link_name, offset)
            for child in self.robot.child_joints(link_name):
                self.link_body(parent, child.child, child, offset)
            return parent
        if joint is None:
            body = ET.SubElement(parent, "body", name=p + link_name, **_origin_attrs(offset))
            if not self.opt.fixed_base:
                ET.SubElement(body, "freejoint", name=f"{p}{link_name}_free")
        else:
            pose = offset @ joint.origin.transform
            body = ET.SubElement(parent, "body", name=p + link_name, **_origin_attrs(pose))
            self.joint_elements(body, joint)
        moving = joint is not None and joint.type is not JointType.FIXED
        moving = moving or (joint is None and not self.opt.fixed_base)
        inertial, warning = resolve_inertial(link, moving, self.opt.inertia, self.meshes)
        self.inertials[link_name] = inertial
        if warning is not None:
            self.warn(warning)
        if inertial is not None:
            rot = inertial.origin.transform.rotation
            t = rot @ inertial.tensor @ rot.T
            ET.SubElement(
                body,
                "inertial",
                mass=fmt(inertial.mass),
                pos=fmt(inertial.origin.xyz),
                fullinertia=fmt((t[0, 0], t[1, 1], t[2, 2], t[0, 1], t[0, 2], t[1, 2])),
            )
        self.link_geoms(body, link_name, Transform.identity())
        for child in self.robot.child_joints(link_name):
            self.link_body(body, child.child, child, Transform.identity())
        return body

    def link_geoms(self, body: ET.Element, link_name: str, offset: Transform) -> None:
        """Visual and collision geoms of `link_name`, each origin premultiplied by `offset`.

        Visual meshes whose file was not found are left out (the parser warned about each);
        a missing collision mesh is an error, since the robot would collide differently.
        """
        p = self.opt.prefix
        link = self.robot.links[link_name]
        for i, vis in enumerate(link.visuals):
            if isinstance(vis.geometry, Mesh) and vis.geometry.path is None:
                continue
            pose = offset @ vis.origin.transform
            urdf_rgba = vis.material.rgba if vis.material and vis.material.rgba else None
            for geom, part in self.visual_geoms(
                body, f"{p}{link_name}/visual/{i}", vis.geometry, pose
            ):
                geom.attrib.update(
                    contype="0", conaffinity="0", group=str(VISUAL_GROUP), density="0"
                )
                if part is not None and part.texture is not None:
                    geom.set("material", self.textured_material(geom.get("name", ""), part))
                    continue
                own = part.rgba if part is not None else None
                geom.set("rgba", fmt(own or urdf_rgba or self.opt.default_rgba))
        bits = ("1", "1") if self.opt.self_collision else ("2", "1")
        for i, col in enumerate(link.collisions):
            name = f"{p}{link_name}/collision/{i}"
            geometry, pose = self.collision_shape(name, col.geometry, offset @ col.origin.transform)
            geom = self.geom(body, name, geometry, pose)
            geom.attrib.update(
                contype=bits[0],
                conaffinity=bits[1],
                group=str(COLLISION_GROUP),
                rgba=fmt(self.opt.collision_rgba),
            )

    def textured_material(self, name: str, part: MeshPart) -> str:
        """A MuJoCo material drawing `part`'s texture (its UVs are in the OBJ file)."""
        assert part.texture is not None
        ET.SubElement(self.doc.asset, "texture", name=name, type="2d", file=str(part.texture))
        attrs = {"name": name, "texture": name}
        if part.rgba is not None:
            attrs["rgba"] = fmt(part.rgba)
        ET.SubElement(self.doc.asset, "material", attrs)
        return name

    def joint_elements(self, body: ET.Element, joint: Joint) -> None:
        name = self.opt.prefix + joint.name
        common = {
            "damping": fmt(joint.dynamics.damping),
            "frictionloss": fmt(joint.dynamics.friction),
            "armature": fmt(self.opt.armature),
        }
        created: list[str] = []

        def add(jname: str, jtype: str, axis: Iterable[float] | None = None, **extra: str) -> None:
            attrs = {"name": jname, "type": jtype, **common, **extra}
            if axis is not None:
                attrs["axis"] = fmt(axis)
            ET.SubElement(body, "joint", attrs)
            created.append(jname)

        jt = joint.type
        if jt in (JointType.REVOLUTE, JointType.CONTINUOUS, JointType.PRISMATIC):
            extra = {}
            if joint.limited and joint.limit is not None:
                extra = {"range": fmt((joint.limit.lower, joint.limit.upper)), "limited": "true"}
            add(name, "slide" if jt is JointType.PRISMATIC else "hinge", joint.axis, **extra)
        elif jt is JointType.PLANAR:
            u, v = plane_basis(joint.axis)
            add(f"{name}_x", "slide", u)
            add(f"{name}_y", "slide", v)
            add(f"{name}_theta", "hinge", joint.axis)
        elif jt is JointType.FLOATING:
            for axis_name, axis in zip("xyz", np.eye(3), strict=True):
                add(f"{name}_{axis_name}", "slide", axis)
            add(f"{name}_rot", "ball")
        self.mappings[joint.name] = JointMapping(joint, tuple(created))

    def mimics(self) -> None:
        p = self.opt.prefix
        for joint in self.robot.joints.values():
            if joint.mimic is not None:
                ET.SubElement(
                    self.doc.section("equality"),
                    "joint",
                    name=f"{p}{joint.name}/mimic",
                    joint1=p + joint.name,
                    joint2=p + joint.mimic.joint,
                    polycoef=fmt((joint.mimic.offset, joint.mimic.multiplier, 0, 0, 0)),
                )


def add_robot(
    doc: MjcfDocument,
    robot: Robot,
    options: MjcfOptions | None = None,
    meshes: MeshCache | None = None,
) -> RobotMjcf:
    """Add `robot` under `doc`'s worldbody; warnings (replaced inertials...) are also emitted."""
    opts = options or MjcfOptions()
    builder = _Builder(doc, robot, opts, meshes or MeshCache())
    builder.link_body(doc.worldbody, robot.root, None, opts.base)
    builder.mimics()
    return RobotMjcf(robot, opts, builder.mappings, tuple(builder.warnings), builder.inertials)


def robot_to_mjcf(
    robot: Robot, options: MjcfOptions | None = None
) -> tuple[MjcfDocument, RobotMjcf]:
    """A standalone document holding just `robot` (fixed to the world unless told otherwise)."""
    doc = MjcfDocument(robot.name)
    return doc, add_robot(doc, robot, options)
