"""Parse URDF XML into a validated `Robot`; malformed input raises `UrdfError` naming it.

Conventions real files use but the URDF spec frowns on (a joint defined twice, a mimic
of a joint that does not exist, a material named before it is defined) load with a
warning naming the file, line and element; `strict=True` turns them into errors.

A joint is known by its child link, as Unity's URDF importer builds the tree: a second
joint that reuses a name for another child (Unity's niryo_one.urdf names both
hand_link -> tool_link and tool_link -> gripper_base `hand_tool_joint`) is kept under a
unique name; one that repeats the name and the child is a duplicate and the first counts.
"""

from __future__ import annotations

import math
import warnings
import xml.etree.ElementTree as ET
from dataclasses import replace
from pathlib import Path

from simbridge.errors import UrdfError
from simbridge.sim.urdf.diagnostics import UrdfWarning
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
from simbridge.sim.urdf.transforms import Vec3
from simbridge.sim.urdf.xmllines import SourceTree, parse_with_lines

__all__ = ["parse_urdf"]

_JOINT_TYPES = {t.value: t for t in JointType}


class _LocatedError(UrdfError):
    """An error whose text already names the file and line (not prefixed again)."""


def _floats(text: str | None, count: int, where: str, attr: str) -> tuple[float, ...]:
    if text is None:
        raise UrdfError(f"{where}: missing attribute '{attr}'")
    parts = text.split()
    if len(parts) != count:
        raise UrdfError(
            f"{where}: attribute {attr}='{text}' needs {count} number(s), got {len(parts)}"
        )
    try:
        values = tuple(float(p) for p in parts)
    except ValueError:
        raise UrdfError(f"{where}: attribute {attr}='{text}' is not a number") from None
    if any(math.isinf(v) for v in values):
        raise UrdfError(f"{where}: attribute {attr}='{text}' is infinite")
    return values


def _float(elem: ET.Element, attr: str, where: str, default: float | None = None) -> float:
    text = elem.get(attr)
    if text is None:
        if default is None:
            raise UrdfError(f"{where}: <{elem.tag}> is missing attribute '{attr}'")
        return default
    return _floats(text, 1, where, attr)[0]


def _vec3(elem: ET.Element | None, attr: str, where: str, default: Vec3) -> Vec3:
    if elem is None or elem.get(attr) is None:
        return default
    x, y, z = _floats(elem.get(attr), 3, f"{where} <{elem.tag}>", attr)
    return (x, y, z)


def _origin(parent: ET.Element, where: str) -> Origin:
    elem = parent.find("origin")
    return Origin(
        _vec3(elem, "xyz", where, (0.0, 0.0, 0.0)), _vec3(elem, "rpy", where, (0.0, 0.0, 0.0))
    )


class _Parser:
    """One parse of one document; collects warnings as it goes."""

    def __init__(self, tree: SourceTree, resolver: ResourceResolver | None, strict: bool) -> None:
        self.tree, self.resolver, self.strict = tree, resolver, strict
        self.warnings: list[str] = []
        self.materials: dict[str, Material] = {}

    def lenient(self, elem: ET.Element | None, message: str) -> None:
        """A defect real files carry: a warning, or an error in strict mode."""
        text = f"{self.tree.at(elem)}{message}"
        if self.strict:
            raise _LocatedError(f"{text} (strict mode)")
        self.warn(text)

    def warn(self, text: str) -> None:
        """Record and emit a warning (text already names the file)."""
        self.warnings.append(text)
        warnings.warn(text, UrdfWarning, stacklevel=4)

    def fail(self, elem: ET.Element | None, message: str) -> UrdfError:
        """An error naming the file and line of `elem`."""
        return _LocatedError(f"{self.tree.at(elem)}{message}")

    def material(self, elem: ET.Element, where: str) -> Material:
        name = elem.get("name", "")
        color = elem.find("color")
        rgba: tuple[float, float, float, float] | None = None
        if color is not None:
            r, g, b, a = _floats(color.get("rgba"), 4, f"{where} material '{name}' <color>", "rgba")
            rgba = (r, g, b, a)
        texture_elem = elem.find("texture")
        texture = texture_elem.get("filename") if texture_elem is not None else None
        return Material(name, rgba, texture)

    def geometry(self, parent: ET.Element, where: str) -> Geometry:
        geom = parent.find("geometry")
        if geom is None or len(geom) == 0:
            raise UrdfError(f"{where}: <geometry> is missing or empty")
        shape = geom[0]
        what = f"{where} <{shape.tag}>"
        if shape.tag == "box":
            x, y, z = _floats(shape.get("size"), 3, what, "size")
            if min(x, y, z) < 0:
                raise UrdfError(f"{what}: size='{shape.get('size')}' has a negative edge")
            return Box((x, y, z))
        if shape.tag == "cylinder":
            radius, length = _float(shape, "radius", what), _float(shape, "length", what)
            if radius <= 0 or length <= 0:
                raise UrdfError(f"{what}: radius and length must be positive")
            return Cylinder(radius, length)
        if shape.tag == "sphere":
            radius = _float(shape, "radius", what)
            if radius <= 0:
                raise UrdfError(f"{what}: radius must be positive, got {radius}")
            return Sphere(radius)
        if shape.tag == "mesh":
            filename = shape.get("filename")
            if not filename:
                raise UrdfError(f"{what}: missing attribute 'filename'")
            scale = _vec3(shape, "scale", what, (1.0, 1.0, 1.0))
            path: Path | None = None
            if self.resolver is not None:
                try:
                    path = self.resolver.resolve(filename, what)
                except UrdfError as exc:
                    self.lenient(shape, str(exc))
            return Mesh(filename, scale, path)
        raise UrdfError(
            f"{where}: unknown geometry <{shape.tag}> (valid: box, cylinder, sphere, mesh)"
        )

    def inertial(self, elem: ET.Element, where: str) -> Inertial:
        what = f"{where} <inertial>"
        mass_elem = elem.find("mass")
        mass = _float(mass_elem, "value", what) if mass_elem is not None else 0.0
        inertia = elem.find("inertia")
        values = dict.fromkeys(("ixx", "ixy", "ixz", "iyy", "iyz", "izz"), 0.0)
        if inertia is not None:
            for key in values:
                values[key] = _float(inertia, key, what, 0.0)
        return Inertial(mass, _origin(elem, what), **values)

    def link(self, elem: ET.Element) -> Link:
        name = elem.get("name")
        if not name:
            raise self.fail(elem, "<link> without a 'name' attribute")
        try:
            return self._link(elem, name)
        except _LocatedError:
            raise
        except UrdfError as exc:
            raise self.fail(elem, str(exc)) from None

    def visual_material(self, mat_elem: ET.Element, where: str) -> Material | None:
        """The material of a visual: its own colour/texture, or a named one defined earlier
        (at robot level or, as urdfdom allows, in an earlier visual)."""
        local = self.material(mat_elem, where)
        if local.rgba is None and local.texture is None:
            if local.name in self.materials:
                return self.materials[local.name]
            self.lenient(
                mat_elem,
                f"{where}: material '{local.name}' is not defined "
                f"(defined: {', '.join(sorted(self.materials)) or 'none'}); "
                "drawing it in the default colour",
            )
            return None
        if local.name and local.name not in self.materials:
            self.materials[local.name] = local
        return local

    def _link(self, elem: ET.Element, name: str) -> Link:
        where = f"link '{name}'"
        inertial_elem = elem.find("inertial")
        inertial = self.inertial(inertial_elem, where) if inertial_elem is not None else None
        visuals = []
        for i, vis in enumerate(elem.findall("visual")):
            vwhere = f"{where} <visual> #{i}"
            mat_elem = vis.find("material")
            material: Material | None = None
            if mat_elem is not None:
                material = self.visual_material(mat_elem, vwhere)
            visuals.append(
                Visual(self.geometry(vis, vwhere), _origin(vis, vwhere), material, vis.get("name"))
            )
        collisions = [
            Collision(
                self.geometry(col, f"{where} <collision> #{i}"),
                _origin(col, f"{where} <collision> #{i}"),
                col.get("name"),
            )
            for i, col in enumerate(elem.findall("collision"))
        ]
        return Link(name, inertial, tuple(visuals), tuple(collisions))

    def joint(self, elem: ET.Element) -> Joint:
        name = elem.get("name")
        if not name:
            raise self.fail(elem, "<joint> without a 'name' attribute")
        try:
            return self._joint(elem, name)
        except _LocatedError:
            raise
        except UrdfError as exc:
            raise self.fail(elem, str(exc)) from None

    def _joint(self, elem: ET.Element, name: str) -> Joint:
        where = f"joint '{name}'"
        type_name = elem.get("type")
        if type_name not in _JOINT_TYPES:
            raise UrdfError(
                f"{where}: unknown joint type '{type_name}' (valid: {', '.join(_JOINT_TYPES)})"
            )
        jtype = _JOINT_TYPES[type_name]
        ends: dict[str, str] = {}
        for tag in ("parent", "child"):
            end = elem.find(tag)
            link = end.get("link") if end is not None else None
            if not link:
                raise UrdfError(f"{where}: missing <{tag} link='...'>")
            ends[tag] = link
        axis_elem = elem.find("axis")
        axis = _vec3(axis_elem, "xyz", where, (1.0, 0.0, 0.0))
        norm = math.sqrt(sum(a * a for a in axis))
        if jtype not in (JointType.FIXED, JointType.FLOATING):
            if norm < 1e-12:
                text = axis_elem.get("xyz") if axis_elem is not None else ""
                raise UrdfError(f"{where}: <axis xyz='{text}'> is zero")
            axis = (axis[0] / norm, axis[1] / norm, axis[2] / norm)
        limit: JointLimit | None = None
        limit_elem = elem.find("limit")
        if limit_elem is not None:
            lw = f"{where} <limit>"
            limit = JointLimit(
                _float(limit_elem, "lower", lw, 0.0),
                _float(limit_elem, "upper", lw, 0.0),
                _float(limit_elem, "effort", lw, 0.0),
                _float(limit_elem, "velocity", lw, 0.0),
            )
            if limit.lower > limit.upper:
                raise UrdfError(f"{lw}: lower={limit.lower} is above upper={limit.upper}")
            if limit.effort < 0 or limit.velocity < 0:
                raise UrdfError(f"{lw}: effort and velocity must not be negative")
            if jtype in (JointType.REVOLUTE, JointType.PRISMATIC) and limit.lower == limit.upper:
                given = "no lower/upper" if limit_elem.get("lower") is None else "lower == upper"
                self.warn(
                    f"{self.tree.at(limit_elem)}{lw}: {given} (range [{limit.lower:g}, "
                    f"{limit.upper:g}]); simulating the joint without position limits"
                )
        elif jtype in (JointType.REVOLUTE, JointType.PRISMATIC):
            raise UrdfError(f"{where}: a {jtype.value} joint needs a <limit> element")
        dyn_elem = elem.find("dynamics")
        dynamics = JointDynamics()
        if dyn_elem is not None:
            dw = f"{where} <dynamics>"
            dynamics = JointDynamics(
                _float(dyn_elem, "damping", dw, 0.0), _float(dyn_elem, "friction", dw, 0.0)
            )
            if dynamics.damping < 0 or dynamics.friction < 0:
                raise UrdfError(f"{dw}: damping and friction must not be negative")
        mimic: Mimic | None = None
        mimic_elem = elem.find("mimic")
        if mimic_elem is not None:
            leader = mimic_elem.get("joint")
            if not leader:
                raise UrdfError(f"{where} <mimic>: missing attribute 'joint'")
            mw = f"{where} <mimic>"
            if not jtype.is_single_dof:
                self.lenient(
                    mimic_elem, f"{where}: a {jtype.value} joint cannot mimic; ignoring <mimic>"
                )
            else:
                mimic = Mimic(
                    leader,
                    _float(mimic_elem, "multiplier", mw, 1.0),
                    _float(mimic_elem, "offset", mw, 0.0),
                )
        return Joint(
            name,
            jtype,
            ends["parent"],
            ends["child"],
            _origin(elem, where),
            axis,
            limit,
            dynamics,
            mimic,
        )


def _cycle(parent_of: dict[str, str], joints: dict[str, Joint], start: str) -> list[str]:
    """The links of the loop reached by walking up parent joints from `start`."""
    seen: list[str] = []
    link = start
    while link not in seen:
        seen.append(link)
        link = joints[parent_of[link]].parent
    return seen[seen.index(link) :]


def _duplicate(parser: _Parser, elem: ET.Element, what: str, first_line: int | None) -> None:
    """A repeated definition (a link's name, a joint's name and child): the first counts."""
    where = f" (line {first_line})" if first_line is not None else ""
    parser.lenient(elem, f"{what} is defined twice; keeping the first definition{where}")


def _joint_repeat(joint: Joint, first: Joint) -> str:
    """How a joint repeating `first`'s name and child link is named in the warning: the
    ends when the parents differ, the name it is kept under when that is another."""
    what = f"joint '{joint.name}'"
    if joint.parent != first.parent:
        what += f" ({joint.parent} -> {joint.child}; the first: {first.parent} -> {first.child})"
    if first.name != joint.name:
        what += f" (kept as '{first.name}')"
    return what


def _unique_name(name: str, taken: set[str]) -> str:
    """`name_2`, `name_3`...: the first that no joint of the file is called."""
    number = 2
    while f"{name}_{number}" in taken:
        number += 1
    return f"{name}_{number}"


def _reused_name(joint: Joint, unique: str, first: tuple[Joint, int | None]) -> str:
    """The warning for a joint that takes an earlier joint's name for another child link."""
    earlier, line = first
    where = f"line {line}" if line is not None else "the first"
    return (
        f"joint '{joint.name}' is defined twice for different links ({where}: "
        f"{earlier.parent} -> {earlier.child}; this one: {joint.parent} -> {joint.child}); "
        f"keeping both, this one as '{unique}'"
    )


def parse_urdf(
    text: str,
    *,
    source: Path | None = None,
    resolver: ResourceResolver | None = None,
    strict: bool = False,
    lines_valid: bool = True,
) -> Robot:
    """Parse and validate URDF `text`; `resolver` (if given) resolves mesh files.

    Missing mesh files are recorded as warnings (the mesh keeps `path=None`). Messages
    start with `source` and the element's line (`lines_valid=False` for xacro output,
    whose lines are not the file's).
    """
    tree = parse_with_lines(text, source, lines_valid)
    root = tree.root
    if root.tag != "robot":
        raise UrdfError(f"{tree.at(root)}root element is <{root.tag}>, expected <robot>")
    parser = _Parser(tree, resolver, strict)
    robot_name = root.get("name")
    if not robot_name:
        robot_name = source.name.split(".")[0] if source is not None else "robot"
        parser.lenient(root, f"<robot> is missing attribute 'name'; calling it '{robot_name}'")
    for elem in root.findall("material"):
        mat = parser.material(elem, "robot")
        if not mat.name:
            raise parser.fail(elem, "robot <material> without a 'name' attribute")
        if mat.name in parser.materials:
            parser.lenient(elem, f"material '{mat.name}' is defined twice; keeping the first")
        else:
            parser.materials[mat.name] = mat
    link_lines: dict[str, int | None] = {}
    links: dict[str, Link] = {}
    for elem in root.findall("link"):
        link = parser.link(elem)
        if link.name in links:
            _duplicate(parser, elem, f"link '{link.name}'", link_lines[link.name])
            continue
        link_lines[link.name] = tree.line(elem)
        links[link.name] = link
    if not links:
        raise UrdfError(f"{tree.at(root)}robot '{robot_name}' has no <link>")
    joints: dict[str, Joint] = {}
    parent_of: dict[str, str] = {}
    joint_elems: dict[str, ET.Element] = {}
    declared = {elem.get("name", "") for elem in root.findall("joint")}
    # Definitions seen so far under each name in the file: child link -> (joint, line).
    seen: dict[str, dict[str, tuple[Joint, int | None]]] = {}
    for elem in root.findall("joint"):
        joint = parser.joint(elem)
        same_name = seen.setdefault(joint.name, {})
        if joint.child in same_name:
            first, line = same_name[joint.child]
            _duplicate(parser, elem, _joint_repeat(joint, first), line)
            continue
        if same_name:
            unique = _unique_name(joint.name, declared)
            parser.lenient(elem, _reused_name(joint, unique, next(iter(same_name.values()))))
            declared.add(unique)
            joint = replace(joint, name=unique)
        same_name[joint.child] = (joint, tree.line(elem))
        for role, link_name in (("parent", joint.parent), ("child", joint.child)):
            if link_name not in links:
                raise parser.fail(
                    elem,
                    f"joint '{joint.name}': {role} link '{link_name}' is not defined "
                    f"(links: {', '.join(sorted(links))})",
                )
        if joint.child in parent_of:
            raise parser.fail(
                elem,
                f"joint '{joint.name}': link '{joint.child}' already has parent joint "
                f"'{parent_of[joint.child]}' (a link has one parent)",
            )
        parent_of[joint.child] = joint.name
        joints[joint.name] = joint
        joint_elems[joint.name] = elem
    for name, joint in list(joints.items()):
        if joint.mimic is None:
            continue
        leader = joints.get(joint.mimic.joint)
        mimic_elem = joint_elems[name].find("mimic")
        if leader is None:
            parser.lenient(
                mimic_elem,
                f"joint '{name}' <mimic>: joint '{joint.mimic.joint}' is not defined; "
                "the joint moves on its own",
            )
            joints[name] = replace(joint, mimic=None)
        elif not leader.type.is_single_dof or leader.mimic is not None or leader is joint:
            raise parser.fail(
                mimic_elem,
                f"joint '{name}' <mimic>: joint '{leader.name}' must be a revolute, "
                "continuous or prismatic joint that mimics nothing itself",
            )
    roots = [name for name in links if name not in parent_of]
    if not roots:
        loop = _cycle(parent_of, joints, next(iter(links)))
        raise UrdfError(
            f"{tree.at(root)}the joints form a cycle through link(s) {' -> '.join(loop)}: "
            "every link has a parent, so there is no root"
        )
    if len(roots) > 1:
        raise UrdfError(
            f"{tree.at(root)}more than one root link: {', '.join(roots)} (connect them with joints)"
        )
    robot = Robot(robot_name, links, joints, roots[0], parser.materials, source, (), text)
    reached = set(robot.links_depth_first())
    unreached = [name for name in links if name not in reached]
    if unreached:
        loop = _cycle(parent_of, joints, unreached[0])
        raise UrdfError(
            f"{tree.at(root)}the joints form a cycle through link(s) {' -> '.join(loop)} "
            f"(unreachable from root '{roots[0]}': {', '.join(unreached)})"
        )
    return replace(robot, warnings=tuple(parser.warnings))
