"""ROS parameters the sim sets for its robots: each robot's URDF as `robot_description`,
named by its namespace, for RViz's RobotModel and robot_state_publisher."""

from __future__ import annotations

import logging

from simbridge.sim.ros.names import resolve_name
from simbridge.sim.urdf.description import robot_description
from simbridge.sim.world.world import World

__all__ = ["description_params"]

_log = logging.getLogger("simbridge.sim.ros")


def description_params(world: World) -> dict[str, str]:
    """The `robot_description` parameter of every robot in `world`: `<ns>/robot_description`
    for a robot with a `ros:` namespace, `/robot_description` for the robot of a scene
    without one (`/<robot name>/robot_description` each when several share the root)."""
    params: dict[str, str] = {}
    plain = [r for r in world.robots.values() if r.built.spec.ros is None]
    for robot in world.robots.values():
        ros = robot.built.spec.ros
        if ros is not None:
            name = resolve_name(ros.namespace, "robot_description")
        elif len(plain) == 1:
            name = "/robot_description"
        else:
            name = f"/{robot.name}/robot_description"
        if name in params:
            _log.warning("robots share the namespace of %s; RViz sees only one of them", name)
        params[name] = robot_description(robot.robot)
    return params
