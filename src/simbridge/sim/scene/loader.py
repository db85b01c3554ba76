"""Read a scene YAML file into a `Scene`; every mistake raises `SimError` naming the key."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any, TypeVar

from simbridge.errors import SimError, did_you_mean
from simbridge.sim.control.diff_drive import DiffDriveConfig, DiffDriveLimits
from simbridge.sim.control.drive import DriveMode, DriveSpec
from simbridge.sim.scene.efforts import EFFORT_POLICIES
from simbridge.sim.scene.located import LineList, LineMap, Where, plain, read_yaml
from simbridge.sim.scene.spec import (
    INTEGRATORS,
    CommandTopics,
    ControllerSpec,
    GripperControllerSpec,
    GroupControllerSpec,
    JointConstraint,
    LightSpec,
    ObjectSpec,
    PhysicsSettings,
    RobotRos,
    RobotSpec,
    RosSettings,
    Scene,
    TrajectoryControllerSpec,
)
from simbridge.sim.sensors.config import OptionError
from simbridge.sim.sensors.suite import SENSOR_CONFIGS, sensor_config
from simbridge.sim.urdf.loader import is_xacro
from simbridge.sim.urdf.robot import Origin
from simbridge.sim.urdf.transforms import Vec3

__all__ = ["SHAPES", "load_scene", "parse_scene", "with_overrides"]

SHAPES = ("box", "sphere", "cylinder", "plane", "mesh")
LIGHTS = ("spot", "directional")
T = TypeVar("T")


class _Section:
    """A mapping from the YAML with its location, so errors say e.g. `scene.yaml:7:
    robots[0].base: ...`; every entry and key read goes into `locations` for the builder's."""

    def __init__(self, data: object, where: Where, locations: dict[str, Where]) -> None:
        if data is None:
            data = {}
        if not isinstance(data, Mapping):
            raise where.error(f"expected a mapping of keys, got {_kind(data)}")
        self.data: Mapping[str, Any] = data
        self.where = where
        self.locations = locations
        locations.setdefault(str(where), where)

    def line(self, name: str) -> int | None:
        """The line of key `name` in the file, if the data came from one."""
        return self.data.key_lines.get(name) if isinstance(self.data, LineMap) else None

    def done(self, known: tuple[str, ...]) -> None:
        """Every key of the mapping must be one of `known`."""
        for key in self.data:
            if key not in known:
                raise self.where.at(self.line(key)).error(
                    f"unknown key '{key}'{did_you_mean(str(key), known)} "
                    f"(valid: {', '.join(known)})"
                )

    def key(self, name: str) -> Where:
        where = self.where.child(f".{name}" if self.where else name, self.line(name))
        self.locations.setdefault(str(where), where)
        return where

    def get(self, name: str, conv: Callable[[Any, Where], T], default: T) -> T:
        if name not in self.data or self.data[name] is None:
            return default
        return conv(self.data[name], self.key(name))

    def optional(self, name: str, conv: Callable[[Any, Where], T]) -> T | None:
        if name not in self.data or self.data[name] is None:
            return None
        return conv(self.data[name], self.key(name))

    def sub(self, name: str) -> _Section:
        return _Section(self.data.get(name), self.key(name), self.locations)

    def items(self, name: str) -> list[_Section]:
        value = self.data.get(name) or []
        where = self.key(name)
        if not isinstance(value, list):
            raise where.error(f"expected a list of entries, got {_kind(value)}")
        lines = value.item_lines if isinstance(value, LineList) else [None] * len(value)
        return [
            _Section(v, where.child(f"[{i}]", line), self.locations)
            for i, (v, line) in enumerate(zip(value, lines, strict=True))
        ]


def _kind(value: object) -> str:
    """How a YAML value reads in an error: a mapping, a list, or the value itself."""
    if isinstance(value, Mapping):
        return "a mapping"
    if isinstance(value, list):
        return "a list"
    return repr(value)


def _number(value: Any, where: Where) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise where.error(f"expected a finite number, got {_kind(value)}")
    return float(value)


def _positive(value: Any, where: Where) -> float:
    number = _number(value, where)
    if number <= 0:
        raise where.error(f"must be > 0, got {number}")
    return number


def _non_negative(value: Any, where: Where) -> float:
    number = _number(value, where)
    if number < 0:
        raise where.error(f"must be >= 0, got {number}")
    return number


def _bool(value: Any, where: Where) -> bool:
    if not isinstance(value, bool):
        raise where.error(f"expected true or false, got {_kind(value)}")
    return value


def _str(value: Any, where: Where) -> str:
    if not isinstance(value, str) or not value:
        raise where.error(f"expected a non-empty string, got {_kind(value)}")
    return value


def _choice(valid: tuple[str, ...]) -> Callable[[Any, Where], str]:
    def conv(value: Any, where: Where) -> str:
        if value not in valid:
            raise where.error(
                f"expected one of {', '.join(valid)}, got {value!r}"
                f"{did_you_mean(str(value), valid)}"
            )
        return str(value)

    return conv


def _topic(value: Any, where: Where) -> str | None:
    if value is False:
        return None
    return _str(value, where)


def _vector(count: int) -> Callable[[Any, Where], tuple[float, ...]]:
    def conv(value: Any, where: Where) -> tuple[float, ...]:
        if not isinstance(value, list | tuple) or len(value) != count:
            raise where.error(f"expected a list of {count} numbers, got {value!r}")
        return tuple(_number(v, where.child(f"[{i}]")) for i, v in enumerate(value))

    return conv


def _vec3(value: Any, where: Where) -> Vec3:
    x, y, z = _vector(3)(value, where)
    return (x, y, z)


def _pose(section: _Section) -> Origin:
    pose = Origin(
        section.get("xyz", _vec3, (0.0, 0.0, 0.0)), section.get("rpy", _vec3, (0.0, 0.0, 0.0))
    )
    section.done(("xyz", "rpy"))
    return pose


def _drive(section: _Section, base: DriveSpec) -> DriveSpec:
    mode = section.get("mode", _drive_mode, base.mode)
    limit = base.force_limit
    if "force_limit" in section.data:
        raw = section.data["force_limit"]
        if raw == "unlimited":
            limit = math.inf
        elif raw is None:
            limit = None
        elif isinstance(raw, str):
            raise section.key("force_limit").error(
                "expected a number > 0, 'unlimited' or null (the effort_limits policy), "
                f"got {raw!r}"
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
        raise section.where.error(str(exc)) from None
    section.done(("mode", "stiffness", "damping", "force_limit"))
    return spec


def _drive_mode(value: Any, where: Where) -> DriveMode:
    try:
        return DriveMode.parse(_str(value, where))
    except SimError as exc:
        raise where.error(str(exc)) from None


def _path(base_dir: Path) -> Callable[[Any, Where], Path]:
    def conv(value: Any, where: Where) -> Path:
        path = Path(_str(value, where)).expanduser()
        return path if path.is_absolute() else base_dir / path

    return conv


def _robot(section: _Section, base_dir: Path) -> RobotSpec:
    if "urdf" not in section.data:
        raise section.where.error("missing key 'urdf' (the robot's URDF or xacro file)")
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
            _path(base_dir)(p, section.key("search_paths").child(f"[{i}]"))
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
        label=section.optional("label", _str),
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
            "label",
        )
    )
    if not spec.urdf.is_file():
        raise section.key("urdf").error(f"file '{spec.urdf}' does not exist")
    return spec


def _namespace(value: Any, where: Where) -> str:
    text = _str(value, where)
    parts = [p for p in text.split("/") if p]
    if any(not p.replace("_", "a").isalnum() or p[0].isdigit() for p in parts):
        raise where.error(
            f"{text!r} is not a ROS namespace (names of letters, digits and _, "
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
        raise entry.where.error("missing key 'joint' (the gripper's driven joint)")
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
            raise entry.key("type").error(
                f"expected one of {', '.join(CONTROLLER_TYPES)}, got {kind!r}"
                f"{did_you_mean(kind, CONTROLLER_TYPES)}"
            )
        if kind == "gripper_action_controller":
            found.append(_gripper(str(name), entry))
            continue
        joints, at = entry.data.get("joints"), entry.key("joints")  # `at`: noted for the builder
        if not isinstance(joints, list) or not joints:
            raise at.error("expected a list of joint names")
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
        raise section.where.error("missing key 'name' (unique among the scene's objects)")
    shape = section.get("type", _str, "")
    if shape not in SHAPES:
        raise section.key("type").error(
            f"unknown shape '{shape}'{did_you_mean(shape, SHAPES)} (valid: {', '.join(SHAPES)})"
        )
    sizes = {"box": 3, "sphere": 1, "cylinder": 2, "plane": 2}
    size: tuple[float, ...] = ()
    if shape in sizes:
        default = (0.0, 0.0) if shape == "plane" else None
        raw = section.data.get("size", default)
        if raw is None:
            raise section.key("size").error(f"missing ({sizes[shape]} numbers for a {shape})")
        if isinstance(raw, int | float) and sizes[shape] == 1:
            raw = [raw]
        size = _vector(sizes[shape])(raw, section.key("size"))
        check = _non_negative if shape == "plane" else _positive
        for i, v in enumerate(size):
            check(v, section.key("size").child(f"[{i}]"))
    friction_raw = section.data.get("friction", 1.0)
    if isinstance(friction_raw, int | float):
        friction_raw = [friction_raw, 0.005, 0.0001]
    fx, fy, fz = _vector(3)(friction_raw, section.key("friction"))
    grey: tuple[float, ...] = (0.6, 0.6, 0.6, 1.0)
    r, g, b, a = section.get("rgba", _vector(4), grey)
    dynamic = section.get("dynamic", _bool, False)
    if dynamic and shape == "plane":
        raise section.key("dynamic").error("a plane cannot be dynamic")
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
        label=section.optional("label", _str),
    )
    if shape == "mesh" and spec.mesh is None:
        raise section.where.error("a mesh object needs key 'mesh' (a file)")
    section.done(
        (
            "name",
            "type",
            "size",
            "pose",
            "dynamic",
            "mass",
            "friction",
            "rgba",
            "mesh",
            "scale",
            "label",
        )
    )
    return spec


def _light(section: _Section) -> LightSpec:
    kind = section.get("type", _str, "spot")
    if kind not in LIGHTS:
        raise section.key("type").error(
            f"unknown light '{kind}'{did_you_mean(kind, LIGHTS)} (valid: {', '.join(LIGHTS)})"
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
        raise section.key("integrator").error(
            f"unknown integrator '{integrator}'{did_you_mean(integrator, INTEGRATORS)} "
            f"(valid: {', '.join(INTEGRATORS)})"
        )
    iterations = section.get("solver_iterations", _positive, 100.0)
    seed = section.get("seed", _non_negative, 0.0)
    if iterations != int(iterations) or seed != int(seed):
        raise section.where.error("solver_iterations and seed must be integers")
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
            raise section.where.error(f"missing key '{key}' (a wheel joint)")
    base, limits = DiffDriveConfig("left", "right"), DiffDriveLimits()
    names = tuple(
        f"max_{q}_{d}" for d in ("velocity", "acceleration") for q in ("linear", "angular")
    )
    values = {n: section.get(n, _positive, getattr(limits, n)) for n in names}
    left, right = section.get("left", _str, ""), section.get("right", _str, "")
    topic = section.get("topic", _str, base.topic)
    radius = section.optional("wheel_radius", _positive)
    separation = section.optional("wheel_separation", _positive)
    timeout = section.get("cmd_timeout", _positive, base.cmd_timeout)
    try:
        config = DiffDriveConfig(
            left_joint=left,
            right_joint=right,
            topic=topic,
            wheel_radius=radius,
            wheel_separation=separation,
            limits=DiffDriveLimits(**values),
            cmd_timeout=timeout,
        )
    except SimError as exc:
        raise section.where.error(str(exc)) from None
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


def _sensor(section: _Section, locations: dict[str, Where]) -> dict[str, Any]:
    """Check one `sensors:` entry (type, options, their types) and return it as a plain
    dict; the mount body is checked when the scene is built, at the line noted here."""
    kind, name = section.data.get("type"), section.data.get("name")
    if not isinstance(kind, str):
        raise section.where.error(f"a sensor needs a 'type' (one of {', '.join(SENSOR_CONFIGS)})")
    if kind not in SENSOR_CONFIGS:
        raise section.key("type").error(
            f"unknown sensor type '{kind}'{did_you_mean(kind, SENSOR_CONFIGS)} "
            f"(valid: {', '.join(SENSOR_CONFIGS)})"
        )
    entry = section.where.child(f" ({kind} {name!r})" if isinstance(name, str) else f" ({kind})")
    config: dict[str, Any] = plain(dict(section.data))
    try:
        sensor_config(config)
    except OptionError as exc:
        raise entry.at(section.line(exc.key) if exc.key else None).error(exc.detail) from None
    except SimError as exc:
        raise entry.error(str(exc)) from None
    locations[f"{section.where}.body"] = entry.child(".body", section.line("body"))
    return config


def parse_scene(data: object, base_dir: Path, source: Path | None = None) -> Scene:
    """Build a `Scene` from parsed YAML `data`; relative paths are taken from `base_dir`.
    Errors name the entry, and the file and line when `data` came from `load_scene`."""
    locations: dict[str, Where] = {}
    root = _Section(data, Where("", str(source) if source is not None else None, None), locations)
    root.done(("physics", "robots", "objects", "lights", "ros", "sensors", "strict", "perception"))
    perception = root.data.get("perception")
    if perception is not None and not isinstance(perception, Mapping):
        raise root.key("perception").error(f"expected a mapping of keys, got {_kind(perception)}")
    scene = Scene(
        physics=_physics(root.sub("physics")),
        robots=tuple(_robot(s, base_dir) for s in root.items("robots")),
        objects=tuple(_object(s, base_dir) for s in root.items("objects")),
        lights=tuple(_light(s) for s in root.items("lights")),
        ros=_ros(root.sub("ros")),
        sensors=tuple(_sensor(s, locations) for s in root.items("sensors")),
        source=source,
        strict=root.get("strict", _bool, False),
        perception=perception,
        locations=locations,
    )
    _unique(root, "objects", [o.name for o in scene.objects])
    _unique(root, "sensors", [str(s.get("name")) for s in scene.sensors])
    return scene


def _unique(root: _Section, section: str, names: list[str]) -> None:
    """Two entries of `section` may not share a name: the second one is reported."""
    entries = root.items(section)
    for i, name in enumerate(names):
        if name in names[:i]:
            raise (
                entries[i]
                .key("name")
                .error(f"the name '{name}' is already taken by {section}[{names.index(name)}]")
            )


def load_scene(path: str | Path) -> Scene:
    """Read the scene YAML file at `path`."""
    file = Path(path)
    return parse_scene(read_yaml(file), file.resolve().parent, file)


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
