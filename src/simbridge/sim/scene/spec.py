"""A scene's parsed specification: robots, objects, lights, physics and ROS interfaces (frozen
dataclasses, independent of MuJoCo)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from simbridge.sim.control.diff_drive import DiffDriveConfig
from simbridge.sim.control.drive import DriveSpec
from simbridge.sim.scene.located import Where
from simbridge.sim.urdf.robot import Origin
from simbridge.sim.urdf.transforms import Vec3

__all__ = [
    "CommandTopics",
    "ControllerSpec",
    "GripperControllerSpec",
    "GroupControllerSpec",
    "JointConstraint",
    "LightSpec",
    "ObjectSpec",
    "PhysicsSettings",
    "RobotRos",
    "RobotSpec",
    "RosSettings",
    "Scene",
    "TrajectoryControllerSpec",
]

INTEGRATORS = ("euler", "implicit", "implicitfast", "rk4")


@dataclass(frozen=True)
class PhysicsSettings:
    """Integration settings; `realtime_factor` 0 runs as fast as possible."""

    timestep: float = 0.002
    gravity: Vec3 = (0.0, 0.0, -9.81)
    solver_iterations: int = 100
    integrator: str = "implicitfast"
    realtime_factor: float = 1.0
    seed: int = 0


@dataclass(frozen=True)
class RobotSpec:
    """A robot from a URDF/xacro file placed at `base`, with its drives."""

    urdf: Path
    name: str | None = None
    prefix: str = ""
    base: Origin = field(default_factory=Origin)
    fixed_base: bool = True
    self_collision: bool = False
    xacro_args: dict[str, str] = field(default_factory=dict)
    search_paths: tuple[Path, ...] = ()
    initial_positions: dict[str, float] = field(default_factory=dict)
    default_drive: DriveSpec = field(default_factory=DriveSpec)
    joint_drives: dict[str, DriveSpec] = field(default_factory=dict)
    armature: float = 0.01
    """Rotor inertia (kg m^2, or kg for prismatic joints) added to every joint: keeps stiff
    drives on light links (wrists, fingers) stable; URDF has no field for it."""
    collada_up_axis: str = "ignore"
    """"ignore" (as rviz: files are authored to look right there) or "honour" COLLADA
    `<up_axis>` (Y_UP/X_UP meshes rotated to Z up)."""
    effort_limits: str = "urdf"
    """What URDF `effort` values become: "urdf" (force limits, with a warning where one
    cannot hold the robot against gravity), "ignore" (unlimited) or "scale"."""
    ros: RobotRos | None = None
    """The robot's own ROS interface (namespace, frame prefix, topics); None: the robot is
    served by the scene-wide `ros:` section as before."""
    label: str | None = None
    """Class name for perception data (simbridge.perception): the robot is one instance."""


@dataclass(frozen=True)
class ObjectSpec:
    """A primitive or mesh body; static unless `dynamic` (then it gets a free joint).

    `size` holds full edge lengths for boxes, (radius,) for spheres, (radius, length) for
    cylinders and (x, y) half extents for planes (0 means infinite).
    """

    name: str
    shape: str
    size: tuple[float, ...] = ()
    pose: Origin = field(default_factory=Origin)
    dynamic: bool = False
    mass: float | None = None
    friction: tuple[float, float, float] = (1.0, 0.005, 0.0001)
    rgba: tuple[float, float, float, float] = (0.6, 0.6, 0.6, 1.0)
    mesh: Path | None = None
    mesh_scale: Vec3 = (1.0, 1.0, 1.0)
    label: str | None = None
    """Class name for perception data (simbridge.perception); None: not labelled."""


@dataclass(frozen=True)
class LightSpec:
    """A light; directional lights shine along `direction` from infinitely far."""

    name: str
    pos: Vec3 = (0.0, 0.0, 3.0)
    direction: Vec3 = (0.0, 0.0, -1.0)
    directional: bool = False
    diffuse: Vec3 = (0.7, 0.7, 0.7)
    cast_shadows: bool = True


@dataclass(frozen=True)
class CommandTopics:
    """Topics the simulator subscribes to (None switches one off)."""

    trajectory: str | None = "/joint_trajectory"
    position: str | None = "/joint_group_position_controller/command"
    velocity: str | None = "/joint_group_velocity_controller/command"
    follow_joint_states: str | None = None


@dataclass(frozen=True)
class JointConstraint:
    """ros_control's per-joint `constraints/<joint>/{trajectory, goal}` (rad or m; 0: none)."""

    trajectory: float = 0.0
    goal: float = 0.0


@dataclass(frozen=True)
class TrajectoryControllerSpec:
    """A `joint_trajectory_controller` with ros_control's parameters (rates in Hz of sim
    time): the follow_joint_trajectory action, `command` and `state` topics."""

    name: str
    joints: tuple[str, ...]
    state_publish_rate: float = 25.0
    action_monitor_rate: float = 20.0
    goal_time: float = 0.0
    """Default goal_time_tolerance (s) after the trajectory's end to meet goal tolerances."""
    stopped_velocity_tolerance: float = 0.01
    constraints: dict[str, JointConstraint] = field(default_factory=dict)
    """URDF joint name -> tolerances (joints not listed: no tolerance)."""


@dataclass(frozen=True)
class GripperControllerSpec:
    """A `gripper_action_controller` (ros_control's parameters) on one driven joint: the
    `gripper_cmd` action (control_msgs/GripperCommand)."""

    name: str
    joint: str
    goal_tolerance: float = 0.01
    stall_velocity_threshold: float = 0.001
    stall_timeout: float = 1.0
    allow_stalling: bool = False
    """A stalled gripper (holding an object) succeeds instead of aborting."""
    action_monitor_rate: float = 20.0


@dataclass(frozen=True)
class GroupControllerSpec:
    """A `joint_group_{position,velocity,effort}_controller`: one std_msgs/Float64MultiArray
    value per joint on `<ns>/<name>/command`; `mode` is "position", "velocity" or "effort"."""

    name: str
    mode: str
    joints: tuple[str, ...]


ControllerSpec = TrajectoryControllerSpec | GripperControllerSpec | GroupControllerSpec
"""Any controller a robot's `ros: controllers:` may list."""


@dataclass(frozen=True)
class RobotRos:
    """A robot's own ROS interface: its topics live under `namespace`, its TF frames are its
    URDF link names with `frame_prefix`, its joint names are the URDF's. Relative topic
    names are resolved in the namespace (as rospy does); /tf, /tf_static and /clock stay
    shared and scene-wide."""

    namespace: str = "/"
    frame_prefix: str = ""
    joint_states_topic: str = "joint_states"
    joint_states_rate: float = 50.0
    commands: CommandTopics = CommandTopics(
        trajectory="joint_trajectory",
        position="joint_group_position_controller/command",
        velocity="joint_group_velocity_controller/command",
    )
    command_joints: tuple[str, ...] = ()
    """URDF joint names the group position/velocity commands address (default: every
    driven joint of the robot)."""
    controllers: tuple[ControllerSpec, ...] = ()
    diff_drive: DiffDriveConfig | None = None
    """The robot's differential-drive base (URDF wheel joint names; a relative `topic`,
    by default `cmd_vel`, resolves in the namespace)."""
    own_connection: bool = False
    """Serve this robot through a connection of its own to the endpoint (a
    `SimulationSession` opens it), so its traffic or failure does not stall the others'."""


@dataclass(frozen=True)
class RosSettings:
    """Which ROS interfaces run and how often (rates in Hz of sim time)."""

    enabled: bool = True
    joint_states_topic: str = "/joint_states"
    joint_states_rate: float = 50.0
    tf: bool = True
    tf_rate: float = 50.0
    clock: bool = True
    clock_rate: float = 100.0
    commands: CommandTopics = CommandTopics()
    command_joints: tuple[str, ...] = ()
    services_prefix: str = "/simbridge"
    diff_drive: DiffDriveConfig | None = None
    """A differential-drive base commanded by geometry_msgs/Twist (None: no base)."""


@dataclass(frozen=True)
class Scene:
    """Everything needed to build a `World`."""

    physics: PhysicsSettings = PhysicsSettings()
    robots: tuple[RobotSpec, ...] = ()
    objects: tuple[ObjectSpec, ...] = ()
    lights: tuple[LightSpec, ...] = ()
    ros: RosSettings = RosSettings()
    sensors: tuple[dict[str, Any], ...] = ()
    """Raw `sensors:` entries, each with a `type`; `simbridge.sim.sensors` interprets them."""
    source: Path | None = None
    strict: bool = False
    """Refuse what is otherwise tolerated with a warning (duplicate URDF definitions,
    out-of-range initial positions...)."""
    perception: Mapping[str, Any] | None = field(default=None, compare=False)
    """The raw `perception:` section (line-aware); `simbridge.perception` interprets it."""
    locations: Mapping[str, Where] = field(default_factory=dict, compare=False)
    """Every entry and key the loader read (`robots[0].drives.joints.j9`, `sensors[1].body`)
    -> where it stands in the file, for the errors found only when the scene is built."""
