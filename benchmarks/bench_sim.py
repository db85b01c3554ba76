"""Simulator speed: physics steps per second and real-time factor for a 6-DoF arm scene.

The Niryo One (6 revolute joints and a mimic gripper) with its default position drives,
alone, following a trajectory, among dynamic boxes, publishing its ROS state through an
in-process endpoint, and paced at real time (which should land on a factor of 1.0).
Column `vs_bare`: steps/s over those of the bare trajectory run measured just before it
in the same run (the ROS row's figure is the cost of publishing the sim's ROS state; the
goal is >= 0.5).
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from typing import Any

from simbridge.assets import robot_urdf
from simbridge.connector import Connector
from simbridge.endpoint import EndpointOptions, EndpointThread
from simbridge.sim.control import Trajectory
from simbridge.sim.ros import SimRosBridge
from simbridge.sim.scene import parse_scene
from simbridge.sim.world import World

ARM_JOINTS = [f"joint_{i}" for i in range(1, 7)]


def _world(boxes: int = 0, timestep: float = 0.002) -> World:
    objects: list[dict[str, Any]] = [{"name": "floor", "type": "plane"}]
    objects += [
        {
            "name": f"box{i}",
            "type": "box",
            "size": [0.03, 0.03, 0.03],
            "dynamic": True,
            "mass": 0.05,
            "pose": {"xyz": [0.25 + 0.04 * (i % 5), -0.1 + 0.05 * (i // 5), 0.015]},
        }
        for i in range(boxes)
    ]
    scene = {
        "physics": {"timestep": timestep},
        "robots": [{"urdf": str(robot_urdf("niryo_one"))}],
        "objects": objects,
    }
    return World.from_scene(parse_scene(scene, robot_urdf("niryo_one").parent))


def _sweep(world: World) -> None:
    """Start a 4 s back-and-forth trajectory over all six arm joints."""
    out = [0.8, -0.6, 0.5, 1.0, -0.8, 1.2]
    traj = Trajectory.from_lists(ARM_JOINTS, [2.0, 4.0], [out, [0.0] * 6])
    world.follower.start(traj, world.time)


def _measure(
    name: str,
    world: World,
    sim_seconds: float,
    factor: float = 0.0,
    setup: Callable[[World], None] | None = None,
) -> dict[str, Any]:
    if setup is not None:
        setup(world)
    stats = world.run(duration=sim_seconds, realtime_factor=factor)
    return {
        "scenario": name,
        "bodies": world.model.nbody,
        "dofs": world.model.nv,
        "timestep_ms": world.timestep * 1e3,
        "steps": stats.steps,
        "steps_per_s": stats.steps / stats.wall_time,
        "realtime_factor": stats.realtime_factor,
    }


def _with_ros(sim_seconds: float) -> dict[str, Any]:
    world = _world()
    with EndpointThread(EndpointOptions(port=0)) as endpoint:
        connector = Connector("127.0.0.1", endpoint.port).connect(wait=5)
        try:
            with SimRosBridge(world, connector):
                row = _measure(
                    "arm + ROS state (js 50 Hz, tf 50 Hz, clock 100 Hz)",
                    world,
                    sim_seconds,
                    setup=_sweep,
                )
                connector.flush(5)
        finally:
            connector.close()
    return row


def run(sim_seconds: float = 20.0) -> list[dict[str, Any]]:
    """One row per scenario; `sim_seconds` of simulated time each (real-time row: 2 s)."""
    holding = _measure("arm holding pose", _world(), sim_seconds)
    bare = _measure("arm following a trajectory", _world(), sim_seconds, setup=_sweep)
    rows = [
        holding,
        bare,
        _with_ros(sim_seconds),  # right after its bare twin: the ratio of one moment
        _measure("arm + 20 dynamic boxes", _world(boxes=20), sim_seconds, setup=_sweep),
        _measure("arm, 1 ms timestep", _world(timestep=0.001), sim_seconds, setup=_sweep),
    ]
    for row in rows:
        row["vs_bare"] = row["steps_per_s"] / bare["steps_per_s"]
    paced = _measure("arm paced at real time", _world(), 2.0, factor=1.0, setup=_sweep)
    return [*rows, {**paced, "vs_bare": ""}]


if __name__ == "__main__":
    from benchmarks.table import format_table

    print(format_table(run(), markdown="--markdown" in sys.argv))
