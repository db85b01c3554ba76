"""What the live-view tests look at: a red one-joint arm (its colour tells its visuals from
the rest) and a world stepping in real time in a LiveView."""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import yaml

from simbridge.sim.scene import load_scene
from simbridge.sim.view import LiveView, ViewOptions
from simbridge.sim.world import World

__all__ = ["ARM", "RED", "red_arm_world", "viewed"]

RED = (0.9, 0.05, 0.05, 1.0)
ARM = f"""<?xml version="1.0"?>
<robot name="red_arm">
  <material name="red"><color rgba="{" ".join(map(str, RED))}"/></material>
  <link name="base">
    <inertial><mass value="5"/>
      <inertia ixx="0.05" iyy="0.05" izz="0.05" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><geometry><cylinder radius="0.08" length="0.1"/></geometry>
      <material name="red"/></visual>
  </link>
  <link name="upper">
    <inertial><origin xyz="0 0 0.2"/><mass value="1"/>
      <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><origin xyz="0 0 0.2"/><geometry><box size="0.08 0.08 0.4"/></geometry>
      <material name="red"/></visual>
  </link>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="upper"/>
    <origin xyz="0 0 0.05"/><axis xyz="0 1 0"/>
    <limit lower="-1.5" upper="1.5" effort="50" velocity="2"/></joint>
</robot>
"""


def red_arm_world(tmp_path: Path, objects: tuple[dict[str, Any], ...] = ()) -> World:
    """ARM fixed at the origin with the scene's `objects` entries, real time, no ROS; the
    files are written into `tmp_path`."""
    (tmp_path / "arm.urdf").write_text(ARM)
    scene = {
        "physics": {"timestep": 0.002, "realtime_factor": 1},
        "robots": [{"urdf": "arm.urdf", "fixed_base": True}],
        "objects": list(objects),
        "ros": {"enabled": False},
    }
    (tmp_path / "scene.yaml").write_text(yaml.safe_dump(scene))
    return World.from_scene(load_scene(tmp_path / "scene.yaml"))


@contextmanager
def viewed(world: World, rate: float = 30.0, realtime_factor: float = 1.0) -> Iterator[LiveView]:
    """`world` stepping at `realtime_factor` x real time on a thread, shown in a live view on
    a port the OS picks; the run stopped and the view closed after."""
    view = LiveView(world, ViewOptions(port=0, rate=rate))
    runner = threading.Thread(target=world.run, kwargs={"realtime_factor": realtime_factor})
    runner.start()
    try:
        yield view
    finally:
        world.stop()
        runner.join(10)
        view.close()
