"""Turn a `Scene` into an MJCF document: robots with drive actuators, objects, lights, physics."""

from __future__ import annotations

import math
import re
import warnings
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from dataclasses import dataclass, replace

from simbridge.errors import SimError, did_you_mean
from simbridge.sim.control.drive import DriveMode, DriveSpec
from simbridge.sim.control.drive_bank import add_drive_actuator
from simbridge.sim.scene.efforts import SCALE_MARGIN, effort_limits, gravity_torques
from simbridge.sim.scene.located import Where
from simbridge.sim.scene.spec import (
    GripperControllerSpec,
    ObjectSpec,
    PhysicsSettings,
    RobotSpec,
    Scene,
)
from simbridge.sim.urdf.diagnostics import UrdfWarning
from simbridge.sim.urdf.document import MjcfDocument, fmt
from simbridge.sim.urdf.inertia import inertial_from_collisions
from simbridge.sim.urdf.loader import load_urdf
from simbridge.sim.urdf.meshes import MeshCache
from simbridge.sim.urdf.mjcf import MjcfOptions, RobotMjcf, add_robot
from simbridge.sim.urdf.robot import (
    Box,
    Collision,
    Cylinder,
    Geometry,
    JointType,
    Mesh,
    Robot,
    Sphere,
)

__all__ = ["BuiltRobot", "BuiltScene", "build_scene"]


@dataclass(frozen=True)
class BuiltRobot:
    """A robot as placed in the model: its scene entry, URDF mapping and resolved drives."""

    name: str
    spec: RobotSpec
    mjcf: RobotMjcf
    drives: dict[str, DriveSpec]
    """MuJoCo joint name -> drive, force limit already resolved from the URDF."""


@dataclass(frozen=True)
class BuiltScene:
    """The document (still editable before compiling) and what went into it."""

    scene: Scene
    document: MjcfDocument
    robots: tuple[BuiltRobot, ...]


# Scene files spell integrators in lower case; MJCF's keywords are case-sensitive.
_MJCF_INTEGRATORS = {"euler": "Euler", "rk4": "RK4"}


def _physics(doc: MjcfDocument, physics: PhysicsSettings) -> None:
    doc.option.attrib.update(
        timestep=fmt(physics.timestep),
        gravity=fmt(physics.gravity),
        iterations=str(physics.solver_iterations),
        integrator=_MJCF_INTEGRATORS.get(physics.integrator, physics.integrator),
    )


def _warn(text: str) -> None:
    warnings.warn(text, UrdfWarning, stacklevel=4)


def _initial_positions(
    robot: Robot, spec: RobotSpec, name: str, where: str, strict: bool
) -> dict[str, float]:
    """Initial positions of the driven joints, clamped into their limits (a warning each;
    an explicit value out of range is an error in strict mode)."""
    resolved: dict[str, float] = {}
    for joint in robot.movable_joints:
        if joint.mimic is not None:
            continue
        explicit = joint.name in spec.initial_positions
        q = spec.initial_positions.get(joint.name, 0.0)
        if joint.limited and joint.limit is not None:
            low, high = joint.limit.lower, joint.limit.upper
            if not low <= q <= high:
                clamped = min(max(q, low), high)
                origin = "initial_positions value" if explicit else "initial position (zero pose)"
                text = (
                    f"{where}robot '{name}' joint '{joint.name}': {origin} {q:g} is outside "
                    f"its limits [{low:g}, {high:g}]"
                )
                if explicit and strict:
                    raise SimError(f"{text} (strict mode)")
                _warn(f"{text}; starting at {clamped:g}")
                q = clamped
        if explicit or q != 0.0:
            resolved[joint.name] = q
    return resolved


def _check_stability(where: str, name: str, joint: str, drive: DriveSpec, dt: float) -> None:
    """Warn about position gains the integrator cannot keep stable (implicit damping
    needs timestep * stiffness / damping < 2)."""
    if drive.mode is not DriveMode.POSITION or drive.stiffness == 0:
        return
    ratio = math.inf if drive.damping == 0 else dt * drive.stiffness / drive.damping
    if ratio >= 2:
        _warn(
            f"{where}robot '{name}' joint '{joint}': drive stiffness {drive.stiffness:g} with "
            f"damping {drive.damping:g} breaks the stability rule timestep * stiffness / "
            f"damping < 2 ({dt:g} * {drive.stiffness:g} / {drive.damping:g} = {ratio:.3g}); "
            f"raise damping above {dt * drive.stiffness / 2:g} or lower the stiffness"
        )


def _located(scene: Scene, path: str) -> Where:
    """Where the scene entry at `path` (`robots[0].drives.joints.j9`) came from: its file and
    line when the scene was read from one (else those of the nearest entry above it that
    was read, e.g. a list's key), else the path alone."""
    head = path
    while head and head not in scene.locations:
        head = re.sub(r"(\.[^.\[]*|\[\d+\]|^[^.\[]*)$", "", head)  # one step up
    found = scene.locations.get(head)  # "": the file alone
    return Where(path) if found is None else Where(path, found.file, found.line)


def _ros_joints(spec: RobotSpec) -> Iterator[tuple[str, str]]:
    """(entry path below the robot, joint name) of every joint its `ros:` block names."""
    if spec.ros is None:
        return
    for controller in spec.ros.controllers:
        at = f"ros.controllers.{controller.name}"
        if isinstance(controller, GripperControllerSpec):
            yield f"{at}.joint", controller.joint
        else:
            yield from ((f"{at}.joints", joint) for joint in controller.joints)
    yield from (("ros.command_joints", joint) for joint in spec.ros.command_joints)
    if spec.ros.diff_drive is not None:
        yield "ros.diff_drive.left", spec.ros.diff_drive.left_joint
        yield "ros.diff_drive.right", spec.ros.diff_drive.right_joint


def _robot(doc: MjcfDocument, scene: Scene, index: int, meshes: MeshCache) -> BuiltRobot:
    spec, strict, physics = scene.robots[index], scene.strict, scene.physics
    robot = load_urdf(
        spec.urdf, search_paths=spec.search_paths, xacro_args=spec.xacro_args, strict=strict
    )
    name = spec.name or robot.name
    where = f"{robot.source}: " if robot.source is not None else ""
    options = MjcfOptions(
        prefix=spec.prefix,
        base=spec.base.transform,
        fixed_base=spec.fixed_base,
        self_collision=spec.self_collision,
        armature=spec.armature,
    )
    if spec.collada_up_axis == "honour":
        meshes = MeshCache(meshes.directory, honour_up_axis=True)
    try:
        mjcf = add_robot(doc, robot, options, meshes)
    except SimError as exc:  # e.g. a second copy of a URDF without a name prefix of its own
        raise _located(scene, f"robots[{index}]").error(str(exc)) from None
    drivable = {j.name: j for j in robot.movable_joints if j.mimic is None}
    for key, joints in (
        ("drives.joints", spec.joint_drives),
        ("initial_positions", spec.initial_positions),
    ):
        for joint_name in joints:
            if joint_name not in drivable:
                raise _located(scene, f"robots[{index}].{key}.{joint_name}").error(
                    f"'{joint_name}' is not a drivable joint of robot '{name}'"
                    f"{did_you_mean(joint_name, drivable)} (revolute/continuous/prismatic "
                    f"without mimic: {', '.join(drivable) or 'none'})"
                )
    spec = replace(spec, initial_positions=_initial_positions(robot, spec, name, where, strict))
    torques = gravity_torques(
        robot, mjcf.inertials, spec.initial_positions, spec.base.transform, physics.gravity
    )
    efforts = {
        j: joint.limit.effort if joint.limit is not None else 0.0 for j, joint in drivable.items()
    }
    limits, factor = effort_limits(spec.effort_limits, efforts, torques)
    if factor > 1.0:
        _warn(
            f"{where}robot '{name}': effort_limits: scale multiplies the URDF efforts by "
            f"{factor:.3g}, so every joint holds {SCALE_MARGIN:g}x its gravity torque"
        )
    drives: dict[str, DriveSpec] = {}
    actuators = doc.section("actuator")
    for joint_name, joint in drivable.items():
        drive = spec.joint_drives.get(joint_name, spec.default_drive)
        source = "scene force_limit"
        if drive.force_limit is None:
            limit = limits[joint_name]
            drive = drive.with_changes(force_limit=math.inf if limit is None else limit)
            source = "URDF effort" if factor == 1.0 else "scaled URDF effort"
        needed = torques.get(joint_name, 0.0)
        assert drive.force_limit is not None
        if drive.mode is not DriveMode.NONE and drive.force_limit < needed:
            unit = "N" if joint.type is JointType.PRISMATIC else "N m"
            _warn(
                f"{where}robot '{name}' joint '{joint_name}': force limit {drive.force_limit:g} "
                f"{unit} ({source}) is below the {needed:.3g} {unit} gravity torque it must "
                "hold at the initial pose, so it will sag (set effort_limits: scale or ignore, "
                f"or drives.joints.{joint_name}.force_limit)"
            )
        _check_stability(where, name, joint_name, drive, physics.timestep)
        mj_name = mjcf.joint_name(joint_name)
        add_drive_actuator(actuators, mj_name, drive.force_limit)
        drives[mj_name] = drive
    world_names = {mjcf.joint_name(j) for j in drivable}  # a `ros:` block may use either
    for key, joint_name in _ros_joints(spec):
        if joint_name not in drivable and joint_name not in world_names:
            raise _located(scene, f"robots[{index}].{key}").error(
                f"'{joint_name}' is not a drivable joint of robot '{name}'"
                f"{did_you_mean(joint_name, drivable)} (valid: {', '.join(drivable) or 'none'})"
            )
    return BuiltRobot(name, spec, mjcf, drives)


def _object_geometry(obj: ObjectSpec, where: Where) -> Geometry | None:
    if obj.shape == "box":
        x, y, z = obj.size
        return Box((x, y, z))
    if obj.shape == "sphere":
        return Sphere(obj.size[0])
    if obj.shape == "cylinder":
        return Cylinder(obj.size[0], obj.size[1])
    if obj.shape == "mesh":
        assert obj.mesh is not None
        if not obj.mesh.is_file():
            raise where.error(f"file '{obj.mesh}' does not exist")
        return Mesh(str(obj.mesh), obj.mesh_scale, obj.mesh)
    return None


def _object(doc: MjcfDocument, scene: Scene, index: int, meshes: MeshCache) -> None:
    obj, where = scene.objects[index], _located(scene, f"objects[{index}]")
    tf = obj.pose.transform
    body = ET.SubElement(
        doc.worldbody, "body", name=obj.name, pos=fmt(tf.translation), quat=fmt(tf.quat_wxyz)
    )
    geom = ET.SubElement(
        body,
        "geom",
        name=obj.name,
        friction=fmt(obj.friction),
        rgba=fmt(obj.rgba),
        contype="1",
        conaffinity="3",
        group="0",
    )
    geometry = _object_geometry(obj, _located(scene, f"objects[{index}].mesh"))
    if geometry is None:
        geom.attrib.update(type="plane", size=fmt((*obj.size, 0.05)))
    elif isinstance(geometry, Box):
        geom.attrib.update(type="box", size=fmt(x / 2 for x in geometry.size))
    elif isinstance(geometry, Sphere):
        geom.attrib.update(type="sphere", size=fmt(geometry.radius))
    elif isinstance(geometry, Cylinder):
        geom.attrib.update(type="cylinder", size=fmt((geometry.radius, geometry.length / 2)))
    else:
        assert isinstance(geometry, Mesh)
        assert geometry.path is not None
        ET.SubElement(
            doc.asset,
            "mesh",
            name=f"object/{obj.name}",
            file=str(meshes.mujoco_file(geometry.path)),
            scale=fmt(geometry.scale),
        )
        geom.attrib.update(type="mesh", mesh=f"object/{obj.name}")
    if obj.dynamic:
        assert geometry is not None
        unit = inertial_from_collisions([Collision(geometry)], 1.0, meshes)
        if unit is None:
            raise where.error(f"object '{obj.name}' has no volume to compute its inertia from")
        scale = (obj.mass if obj.mass is not None else 1000.0 * unit.mass) / unit.mass
        ET.SubElement(body, "freejoint", name=obj.name)
        ET.SubElement(
            body,
            "inertial",
            mass=fmt(unit.mass * scale),
            pos=fmt(unit.origin.xyz),
            fullinertia=fmt(
                v * scale for v in (unit.ixx, unit.iyy, unit.izz, unit.ixy, unit.ixz, unit.iyz)
            ),
        )


def _light(doc: MjcfDocument, scene: Scene, index: int) -> None:
    light = scene.lights[index]
    norm = math.sqrt(sum(c * c for c in light.direction))
    if norm == 0:
        raise _located(scene, f"lights[{index}].dir").error("must not be [0, 0, 0] (a direction)")
    attrs = {
        "pos": fmt(light.pos),
        "dir": fmt(light.direction),
        "diffuse": fmt(light.diffuse),
        "directional": str(light.directional).lower(),
        "castshadow": str(light.cast_shadows).lower(),
    }
    if light.name:
        attrs["name"] = light.name
    ET.SubElement(doc.worldbody, "light", attrs)


def build_scene(scene: Scene, meshes: MeshCache | None = None) -> BuiltScene:
    """Build the MJCF document of `scene` (URDFs are loaded here); compile it with the world."""
    cache = meshes or MeshCache()
    doc = MjcfDocument("scene")
    _physics(doc, scene.physics)
    for i in range(len(scene.lights)):
        _light(doc, scene, i)
    for i in range(len(scene.objects)):
        _object(doc, scene, i, cache)
    robots = tuple(_robot(doc, scene, i, cache) for i in range(len(scene.robots)))
    names = [r.name for r in robots]
    for i, name in enumerate(names):
        if name in names[:i]:
            entry = _located(scene, f"robots[{i}]")
            raise scene.locations.get(f"robots[{i}].name", entry).error(
                f"the robot name '{name}' is already taken by robots[{names.index(name)}] "
                "(set 'name' on each)"
            )
    _check_sensor_bodies(scene, doc)
    return BuiltScene(scene, doc, robots)


def _check_sensor_bodies(scene: Scene, doc: MjcfDocument) -> None:
    """Every sensor's mount body is a body of the model (a link or an object) or the world:
    caught when the scene is built, with or without an endpoint, at the entry's line."""
    bodies = doc.body_names()
    for i, entry in enumerate(scene.sensors):
        body = entry.get("body")
        if not isinstance(body, str) or body in ("", "world") or body in bodies:
            continue
        message = (
            f"no body '{body}' in the scene{did_you_mean(body, bodies)} "
            f"(bodies: {', '.join(bodies)}, world)"
        )
        where = scene.locations.get(f"sensors[{i}].body")
        raise (
            where.error(message)
            if where is not None
            else SimError(f"sensor {entry.get('name')!r}: {message}")
        )
