"""ROS names of a namespaced robot: topics resolved in its namespace, TF frames with its
frame prefix, joint names as in its URDF (the world's MuJoCo names carry the scene prefix)."""

from __future__ import annotations

from simbridge.errors import SimError
from simbridge.sim.world.robot import RobotHandle

__all__ = ["RobotNames", "resolve_name"]


def resolve_name(namespace: str, name: str) -> str:
    """`name` resolved in `namespace` as rospy resolves a relative name: "/x" stays, "x" in
    "/arm_left" becomes "/arm_left/x" ("~" private names are not used here)."""
    if name.startswith("/"):
        return name
    return f"{namespace.rstrip('/')}/{name}"


class RobotNames:
    """Maps one robot's names between the world (MuJoCo, with the scene prefix) and ROS
    (URDF joint names; TF frames with `frame_prefix`)."""

    def __init__(self, robot: RobotHandle, frame_prefix: str) -> None:
        self.robot = robot
        self.frame_prefix = frame_prefix
        self.to_world = {robot.joints[n].joint.name: n for n in robot.joints}
        """URDF joint name -> world joint name."""
        self.to_ros = {w: u for u, w in self.to_world.items()}
        """World joint name -> URDF joint name."""

    def world_joint(self, name: str) -> str:
        """The world name of joint `name` (a URDF name, or already a world name)."""
        found = self.to_world.get(name)
        if found is not None:
            return found
        if name in self.to_ros:
            return name
        raise SimError(
            f"robot {self.robot.name!r} has no joint {name!r} (joints: {', '.join(self.to_world)})"
        )

    def frame(self, world_link: str) -> str:
        """The TF frame of a link given by its world (prefixed) name."""
        prefix = self.robot.prefix
        link = world_link[len(prefix) :] if prefix and world_link.startswith(prefix) else world_link
        return self.frame_prefix + link
