"""Read a scene YAML file into a `Scene`; every mistake raises `SimError` naming the key."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any, TypeVar

import yaml

from simbridge.errors import SimError
from simbridge.sim.control.diff_drive import DiffDriveConfig, DiffDriveLimits
from simbridge.sim.control.drive import DriveMode, DriveSpec
from simbridge.sim.scene.efforts import EFFORT_POLICIES
from simbridge.sim.scene.model import (
    INTEGRATORS,
    CommandTopics,
    ControllerSpec,
    GripperControllerSpec,
    GroupControllerSpec,
    JointConstraint,
    LightSpec,
    ObjectSpec,
    PhysicsSettings,
    Pose,
    RobotRos,
    RobotSpec,
    RosSettings,
    Scene,
    TrajectoryControllerSpec,
)
from simbridge.sim.urdf.loader import is_xacro
from simbridge.sim.urdf.transforms import Vec3

__all__ = ["SHAPES", "load_scene", "parse_scene", "with_overrides"]

SHAPES = ("box", "sphere", "cylinder", "plane", "mesh")
T = TypeVar("T")


class _Section:
    """A mapping from the YAML with its location, so errors say e.g. `robots[0].base.xyz`."""

    def __init__(self, data: object, where: str) -> None:
        if data is None:
            data = {}
        if not isinstance(data, Mapping):
            raise SimError(f"scene {where}: expected a mapping, got {type(data).__name__}")
        self.data: Mapping[str, Any] = data
        self.where = where

    def done(self, known: tuple[str, ...]) -> None:
        unknown = [k for k in self.data if k not in known]
        if unknown:
            raise SimError(
                f"scene {self.where}: unknown key(s) {', '.join(map(str, unknown))} "
                f"(valid: {', '.join(known)})"
            )

    def key(self, name: str) -> str:
        return f"{self.where}.{name}" if self.where else name

    def get(self, name: str, conv: Callable[[Any, str], T], default: T) -> T:
        if name not in self.data or self.data[name] is None:
            return default
        return conv(self.data[name], self.key(name))

    def optional(self, name: str, conv: Callable[[Any, str], T]) -> T | None:
        if name not in self.data or self.data[name] is None:
            return None
        return conv(self.data[name], self.key(name))

    def sub(self, name: str) -> _Section:
        return _Section(self.data.get(name), self.key(name))

    def items(self, name: str) -> list[_Section]:
        value = self.data.get(name) or []
        if not isinstance(value, list):
            raise SimError(f"scene {self.key(name)}: expected a list")
        return [_Section(v, f"{self.key(name)}[{i}]") for i, v in enumerate(value)]


def _number(value: Any, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise SimError(f"scene {where}: expected a finite number, got {value!r}")
    return float(value)


def _positive(value: Any, where: str) -> float:
    number = _number(value, where)
    if number <= 0:
        raise SimError(f"scene {where}: must be > 0, got {number}")
    return number


def _non_negative(value: Any, where: str) -> float:
    number = _number(value, where)
    if number < 0:
        raise SimError(f"scene {where}: must be >= 0, got {number}")
    return number


def _bool(value: Any, where: str) -> bool:
    if not isinstance(value, bool):
        raise SimError(f"scene {where}: expected true or false, got {value!r}")
    return value


def _str(value: Any, where: str) -> str:
    if not isinstance(value, str) or not value:
        raise SimError(f"scene {where}: expected a non-empty string, got {value!r}")
    return value


def _choice(valid: tuple[str, ...]) -> Callable[[Any, str], str]:
    def conv(value: Any, where: str) -> str:
        if value not in valid:
            raise SimError(f"scene {where}: expected one of {', '.join(valid)}, got {value!r}")
        return str(value)

    return conv


def _topic(value: Any, where: str) -> str | None:
    if value is False:
        return None
    return _str(value, where)


def _vector(count: int) -> Callable[[Any, str], tuple[float, ...]]:
    def conv(value: Any, where: str) -> tuple[float, ...]:
        if not isinstance(value, list | tuple) or len(value) != count:
            raise SimError(f"scene {where}: expected a list of {count} numbers, got {value!r}")
        return tuple(_number(v, f"{where}[{i}]") for i, v in enumerate(value))

    return conv


def _vec3(value: Any, where: str) -> Vec3:
    x, y, z = _vector(3)(value, where)
    return (x, y, z)


def _pose(section: _Section) -> Pose:
    pose = Pose(
        section.get("xyz", _vec3, (0.0, 0.0, 0.0)), section.get("rpy", _vec3, (0.0, 0.0, 0.0))
    )
    section.done(("xyz", "rpy"))
    return pose


def _drive(section: _Section, base: DriveSpec) -> DriveSpec:
    mode = section.get("mode", lambda v, w: DriveMode.parse(_str(v, w)), base.mode)
    limit = base.force_limit
    if "force_limit" in section.data:
        raw = section.data["force_limit"]
        if raw == "unlimited":
            limit = math.inf
        elif raw is None:
            limit = None
        elif isinstance(raw, str):
            raise SimError(
                f"scene {section.key('force_limit')}: expected a number > 0, 'unlimited' or "
                f"null (the effort_limits policy), got {raw!r}"
            )
        else:
            limit = _positive(raw, section.key("force_limit"))
    try:
        spec = DriveSpec(
            mode,
            section.get("stiffness", _non_negative, base.stiffness),
            section.get("damping", _non_negative, base.damping),
            limit,
        )
    except SimError as exc:
        raise SimError(f"scene {section.where}: {exc}") from None
    section.done(("mode", "stiffness", "damping", "force_limit"))
    return spec


def _path(base_dir: Path) -> Callable[[Any, str], Path]:
    def conv(value: Any, where: str) -> Path:
        path = Path(_str(value, where)).expanduser()
        return path if path.is_absolute() else base_dir / path

    return conv


def _robot(section: _Section, base_dir: Path) -> RobotSpec:
    if "urdf" not in section.data:
        raise SimError(f"scene {section.where}: missing key 'urdf' (the robot's URDF/xacro file)")
    drives = section.sub("drives")
    default = _drive(drives.sub("default"), DriveSpec())
    joints_section = drives.sub("joints")
    joint_drives = {
        str(name): _drive(joints_section.sub(str(name)), default) for name in joints_section.data
    }
    drives.done(("default", "joints"))
    initial = section.sub("initial_positions")
    xacro_args = section.sub("xacro_args")
    ros = _robot_ros(section.sub("ros")) if "ros" in section.data else None
    # A namespaced robot's MuJoCo names default to its frame prefix (or namespace), so two
    # copies of one URDF need nothing but their `ros:` blocks.
    default_name = (ros.namespace.strip("/") or None) if ros is not None else None
    default_prefix = ""
    if ros is not None:
        default_prefix = ros.frame_prefix or (f"{default_name}/" if default_name else "")
    spec = RobotSpec(
        urdf=section.get("urdf", _path(base_dir), Path()),
        name=section.optional("name", _str) or default_name,
        prefix=section.get("prefix", lambda v, w: str(v), default_prefix),
        ros=ros,
        base=_pose(section.sub("base")),
        fixed_base=section.get("fixed_base", _bool, True),
        self_collision=section.get("self_collision", _bool, False),
        xacro_args={str(k): str(v) for k, v in xacro_args.data.items()},
        search_paths=tuple(
            _path(base_dir)(p, f"{section.key('search_paths')}[{i}]")
            for i, p in enumerate(section.data.get("search_paths") or [])
        ),
        initial_positions={
            str(k): _number(v, initial.key(str(k))) for k, v in initial.data.items()
        },
        default_drive=default,
        joint_drives=joint_drives,
        armature=section.get("armature", _non_negative, RobotSpec.armature),
        effort_limits=section.get("effort_limits", _choice(EFFORT_POLICIES), "urdf"),
        collada_up_axis=section.get("collada_up_axis", _choice(("ignore", "honour")), "ignore"),
    )
    section.done(
        (
            "urdf",
            "name",
            "prefix",
            "base",
            "fixed_base",
            "self_collision",
            "xacro_args",
            "search_paths",
            "initial_positions",
            "drives",
            "armature",
            "effort_limits",
            "collada_up_axis",
            "ros",
        )
    )
    return spec


def _namespace(value: Any, where: str) -> str:
    text = _str(value, where)
    parts = [p for p in text.split("/") if p]
    if any(not p.replace("_", "a").isalnum() or p[0].isdigit() for p in parts):
        raise SimError(
            f"scene {where}: {text!r} is not a ROS namespace (names of letters, digits and _, "
            "not starting with a digit, separated by /, e.g. /arm_left)"
        )
    return "/" + "/".join(parts) if parts else "/"


GROUP_TYPES = {
    "joint_group_position_controller": "position",
    "joint_group_velocity_controller": "velocity",
    "joint_group_effort_controller": "effort",
}
CONTROLLER_TYPES = ("joint_trajectory_controller", "gripper_action_controller", *GROUP_TYPES)


def _gripper(name: str, entry: _Section) -> GripperControllerSpec:
    base = GripperControllerSpec("", "")
    if "joint" not in entry.data:
        raise SimError(f"scene {entry.where}: missing key 'joint' (the gripper's driven joint)")
    spec = GripperControllerSpec(
        name=name,
        joint=entry.get("joint", _str, ""),
        goal_tolerance=entry.get("goal_tolerance", _positive, base.goal_tolerance),
        stall_velocity_threshold=entry.get(
            "stall_velocity_threshold", _positive, base.stall_velocity_threshold
        ),
        stall_timeout=entry.get("stall_timeout", _positive, base.stall_timeout),
        allow_stalling=entry.get("allow_stalling", _bool, base.allow_stalling),
        action_monitor_rate=entry.get("action_monitor_rate", _positive, base.action_monitor_rate),
    )
    entry.done(
        (
            "type",
            "joint",
            "goal_tolerance",
            "stall_velocity_threshold",
            "stall_timeout",
            "allow_stalling",
            "action_monitor_rate",
        )
    )
    return spec


def _controllers(section: _Section) -> tuple[ControllerSpec, ...]:
    found: list[ControllerSpec] = []
    for name in section.data:
        entry = section.sub(str(name))
        kind = entry.get("type", _str, "")
        if kind not in CONTROLLER_TYPES:
            raise SimError(
                f"scene {entry.key('type')}: expected one of {', '.join(CONTROLLER_TYPES)}, "
                f"got {kind!r}"
            )
        if kind == "gripper_action_controller":
            found.append(_gripper(str(name), entry))
            continue
        joints = entry.data.get("joints")
        if not isinstance(joints, list) or not joints:
            raise SimError(f"scene {entry.key('joints')}: expected a list of joint names")
        if kind in GROUP_TYPES:
            found.append(GroupControllerSpec(str(name), GROUP_TYPES[kind], tuple(map(str, joints))))
            entry.done(("type", "joints"))
            continue
        limits = entry.sub("constraints")
        constraints = {}
        for joint in limits.data:
            if joint in ("goal_time", "stopped_velocity_tolerance"):
                continue
            tol = limits.sub(str(joint))
            constraints[str(joint)] = JointConstraint(
                tol.get("trajectory", _non_negative, 0.0), tol.get("goal", _non_negative, 0.0)
            )
            tol.done(("trajectory", "goal"))
        base = TrajectoryControllerSpec("", ())
        found.append(
            TrajectoryControllerSpec(
                name=str(name),
                joints=tuple(str(j) for j in joints),
                state_publish_rate=entry.get(
                    "state_publish_rate", _positive, base.state_publish_rate
                ),
                action_monitor_rate=entry.get(
                    "action_monitor_rate", _positive, base.action_monitor_rate
                ),
                goal_time=limits.get("goal_time", _non_negative, base.goal_time),
                stopped_velocity_tolerance=limits.get(
                    "stopped_velocity_tolerance", _non_negative, base.stopped_velocity_tolerance
                ),
                constraints=constraints,
            )
        )
        entry.done(("type", "joints", "state_publish_rate", "action_monitor_rate", "constraints"))
    return tuple(found)


def _robot_ros(section: _Section) -> RobotRos:
    base = RobotRos()
    commands = section.sub("commands")
    topics = CommandTopics(
        trajectory=commands.get("trajectory", _topic, base.commands.trajectory),
        position=commands.get("position", _topic, base.commands.position),
        velocity=commands.get("velocity", _topic, base.commands.velocity),
        follow_joint_states=commands.get("follow_joint_states", _topic, None),
    )
    commands.done(("trajectory", "position", "velocity", "follow_joint_states"))
    settings = RobotRos(
        namespace=section.get("namespace", _namespace, base.namespace),
        frame_prefix=section.get("frame_prefix", lambda v, w: str(v), base.frame_prefix),
        joint_states_topic=section.get("joint_states_topic", _str, base.joint_states_topic),
        joint_states_rate=section.get("joint_states_rate", _positive, base.joint_states_rate),
        commands=topics,
        command_joints=tuple(str(j) for j in section.data.get("command_joints") or ()),
        controllers=_controllers(section.sub("controllers")),
        own_connection=section.get("own_connection", _bool, False),
        diff_drive=_diff_drive(section.sub("diff_drive")),
    )
    drive = section.sub("diff_drive")
    if settings.diff_drive is not None and "topic" not in drive.data:
        settings = replace(settings, diff_drive=replace(settings.diff_drive, topic="cmd_vel"))
    section.done(
        (
            "controllers",
            "diff_drive",
            "own_connection",
            "namespace",
            "frame_prefix",
            "joint_states_topic",
            "joint_states_rate",
            "commands",
            "command_joints",
        )
    )
    return settings


def _object(section: _Section, base_dir: Path) -> ObjectSpec:
    name = section.get("name", _str, "")
    if not name:
        raise SimError(f"scene {section.where}: missing key 'name'")
    shape = section.get("type", _str, "")
    if shape not in SHAPES:
        raise SimError(
            f"scene {section.key('type')}: unknown shape '{shape}' (valid: {', '.join(SHAPES)})"
        )
    sizes = {"box": 3, "sphere": 1, "cylinder": 2, "plane": 2}
    size: tuple[float, ...] = ()
    if shape in sizes:
        default = (0.0, 0.0) if shape == "plane" else None
        raw = section.data.get("size", default)
        if raw is None:
            raise SimError(
                f"scene {section.key('size')}: missing ({sizes[shape]} numbers for a {shape})"
            )
        if isinstance(raw, int | float) and sizes[shape] == 1:
            raw = [raw]
        size = _vector(sizes[shape])(raw, section.key("size"))
        check = _non_negative if shape == "plane" else _positive
        for i, v in enumerate(size):
            check(v, f"{section.key('size')}[{i}]")
    friction_raw = section.data.get("friction", 1.0)
    if isinstance(friction_raw, int | float):
        friction_raw = [friction_raw, 0.005, 0.0001]
    fx, fy, fz = _vector(3)(friction_raw, section.key("friction"))
    grey: tuple[float, ...] = (0.6, 0.6, 0.6, 1.0)
    r, g, b, a = section.get("rgba", _vector(4), grey)
    dynamic = section.get("dynamic", _bool, False)
    if dynamic and shape == "plane":
        raise SimError(f"scene {section.where}: a plane cannot be dynamic")
    spec = ObjectSpec(
        name=name,
        shape=shape,
        size=size,
        pose=_pose(section.sub("pose")),
        dynamic=dynamic,
        mass=section.optional("mass", _positive),
        friction=(fx, fy, fz),
        rgba=(r, g, b, a),
        mesh=section.optional("mesh", _path(base_dir)),
        mesh_scale=section.get("scale", _vec3, (1.0, 1.0, 1.0)),
    )
    if shape == "mesh" and spec.mesh is None:
        raise SimError(f"scene {section.where}: a mesh object needs key 'mesh' (a file)")
    section.done(
        ("name", "type", "size", "pose", "dynamic", "mass", "friction", "rgba", "mesh", "scale")
    )
    return spec


def _light(section: _Section) -> LightSpec:
    kind = section.get("type", _str, "spot")
    if kind not in ("spot", "directional"):
        raise SimError(
            f"scene {section.key('type')}: unknown light '{kind}' (valid: spot, directional)"
        )
    spec = LightSpec(
        name=section.get("name", _str, ""),
        pos=section.get("pos", _vec3, (0.0, 0.0, 3.0)),
        direction=section.get("dir", _vec3, (0.0, 0.0, -1.0)),
        directional=kind == "directional",
        diffuse=section.get("diffuse", _vec3, (0.7, 0.7, 0.7)),
        cast_shadows=section.get("cast_shadows", _bool, True),
    )
    section.done(("name", "type", "pos", "dir", "diffuse", "cast_shadows"))
    return spec


def _physics(section: _Section) -> PhysicsSettings:
    integrator = section.get("integrator", _str, "implicitfast")
    if integrator not in INTEGRATORS:
        raise SimError(
            f"scene {section.key('integrator')}: unknown integrator '{integrator}' "
            f"(valid: {', '.join(INTEGRATORS)})"
        )
    iterations = section.get("solver_iterations", _positive, 100.0)
    seed = section.get("seed", _non_negative, 0.0)
    if iterations != int(iterations) or seed != int(seed):
        raise SimError(f"scene {section.where}: solver_iterations and seed must be integers")
    settings = PhysicsSettings(
        timestep=section.get("timestep", _positive, 0.002),
        gravity=section.get("gravity", _vec3, (0.0, 0.0, -9.81)),
        solver_iterations=int(iterations),
        integrator=integrator,
        realtime_factor=section.get("realtime_factor", _non_negative, 1.0),
        seed=int(seed),
    )
    section.done(
        ("timestep", "gravity", "solver_iterations", "integrator", "realtime_factor", "seed")
    )
    return settings


def _diff_drive(section: _Section) -> DiffDriveConfig | None:
    if not section.data:
        return None
    for key in ("left", "right"):
        if key not in section.data:
            raise SimError(f"scene {section.where}: missing key '{key}' (a wheel joint)")
    base, limits = DiffDriveConfig("left", "right"), DiffDriveLimits()
    names = tuple(
        f"max_{q}_{d}" for d in ("velocity", "acceleration") for q in ("linear", "angular")
    )
    try:
        config = DiffDriveConfig(
            left_joint=section.get("left", _str, ""),
            right_joint=section.get("right", _str, ""),
            topic=section.get("topic", _str, base.topic),
            wheel_radius=section.optional("wheel_radius", _positive),
            wheel_separation=section.optional("wheel_separation", _positive),
            limits=DiffDriveLimits(
                **{n: section.get(n, _positive, getattr(limits, n)) for n in names}
            ),
            cmd_timeout=section.get("cmd_timeout", _positive, base.cmd_timeout),
        )
    except SimError as exc:
        raise SimError(f"scene {section.where}: {exc}") from None
    section.done(
        ("left", "right", "topic", "wheel_radius", "wheel_separation", "cmd_timeout", *names)
    )
    return config


def _ros(section: _Section) -> RosSettings:
    commands = section.sub("commands")
    defaults = CommandTopics()
    topics = CommandTopics(
        trajectory=commands.get("trajectory", _topic, defaults.trajectory),
        position=commands.get("position", _topic, defaults.position),
        velocity=commands.get("velocity", _topic, defaults.velocity),
        follow_joint_states=commands.get("follow_joint_states", _topic, None),
    )
    commands.done(("trajectory", "position", "velocity", "follow_joint_states"))
    base = RosSettings()
    settings = RosSettings(
        enabled=section.get("enabled", _bool, True),
        joint_states_topic=section.get("joint_states_topic", _str, base.joint_states_topic),
        joint_states_rate=section.get("joint_states_rate", _positive, base.joint_states_rate),
        tf=section.get("tf", _bool, True),
        tf_rate=section.get("tf_rate", _positive, base.tf_rate),
        clock=section.get("clock", _bool, True),
        clock_rate=section.get("clock_rate", _positive, base.clock_rate),
        commands=topics,
        command_joints=tuple(str(j) for j in section.data.get("command_joints") or ()),
        services_prefix=section.get("services_prefix", _str, base.services_prefix),
        diff_drive=_diff_drive(section.sub("diff_drive")),
    )
    section.done(
        (
            "enabled",
            "joint_states_topic",
            "joint_states_rate",
            "tf",
            "tf_rate",
            "clock",
            "clock_rate",
            "commands",
            "command_joints",
            "services_prefix",
            "diff_drive",
        )
    )
    return settings


def _sensor(section: _Section) -> dict[str, Any]:
    if not isinstance(section.data.get("type"), str):
        raise SimError(f"scene {section.where}: a sensor needs a 'type' (e.g. lidar_2d, camera)")
    return dict(section.data)


def parse_scene(data: object, base_dir: Path, source: Path | None = None) -> Scene:
    """Build a `Scene` from parsed YAML `data`; relative paths are taken from `base_dir`."""
    root = _Section(data, "")
    scene = Scene(
        physics=_physics(root.sub("physics")),
        robots=tuple(_robot(s, base_dir) for s in root.items("robots")),
        objects=tuple(_object(s, base_dir) for s in root.items("objects")),
        lights=tuple(_light(s) for s in root.items("lights")),
        ros=_ros(root.sub("ros")),
        sensors=tuple(_sensor(s) for s in root.items("sensors")),
        source=source,
        strict=root.get("strict", _bool, False),
    )
    root.done(("physics", "robots", "objects", "lights", "ros", "sensors", "strict"))
    names = [o.name for o in scene.objects]
    duplicates = sorted({n for n in names if names.count(n) > 1})
    if duplicates:
        raise SimError(f"scene objects: duplicate name(s) {', '.join(duplicates)}")
    return scene


def load_scene(path: str | Path) -> Scene:
    """Read the scene YAML file at `path`."""
    file = Path(path)
    try:
        data = yaml.safe_load(file.read_text())
    except OSError as exc:
        raise SimError(f"scene file '{file}' cannot be read: {exc.strerror}") from None
    except yaml.YAMLError as exc:
        raise SimError(f"scene file '{file}' is not valid YAML: {exc}") from None
    return parse_scene(data, file.resolve().parent, file)


def _is_xacro_file(path: Path) -> bool:
    try:
        return is_xacro(path, path.read_text())
    except OSError:  # a missing file is reported when the robot loads
        return path.suffix == ".xacro"


def with_overrides(scene: Scene, xacro_args: Mapping[str, str], strict: bool = False) -> Scene:
    """`scene` with command-line xacro args set on every xacro robot (over the scene's own
    `xacro_args`) and strict mode switched on if asked; args with no xacro robot are an error."""
    robots = scene.robots
    if xacro_args:
        targets = {i for i, r in enumerate(robots) if _is_xacro_file(r.urdf)}
        if not targets:
            raise SimError(
                f"xacro args {', '.join(sorted(xacro_args))} given, but no robot in the scene "
                "is a xacro file"
            )
        robots = tuple(
            replace(r, xacro_args={**r.xacro_args, **xacro_args}) if i in targets else r
            for i, r in enumerate(robots)
        )
    return replace(scene, robots=robots, strict=scene.strict or strict)
