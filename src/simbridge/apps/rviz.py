"""RViz (ROS 1) for a scene or a demo: its configuration and the command that starts it.

A scene's configuration follows what the scene publishes: a RobotModel per robot (from
the `robot_description` parameter the sim sets), TF, a LaserScan per 2D lidar, a
PointCloud2 per 3D lidar and depth camera, an Image per camera and an Odometry per
odometry sensor, in the frame its odometry broadcasts (`odom`) or else `world`. The
demos ship theirs, written by `rviz_config` (a test keeps them equal).
"""

from __future__ import annotations

import os
import shutil
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from simbridge.apps.mobile_robot.runner import SCENE_PATH as MOBILE_ROBOT_SCENE
from simbridge.apps.pick_and_place.scene import SCENE_PATH as PICK_AND_PLACE_SCENE
from simbridge.errors import AppError
from simbridge.sim.ros import description_params
from simbridge.sim.ros.state_publisher import WORLD_FRAME
from simbridge.sim.scene.loader import load_scene
from simbridge.sim.scene.spec import Scene
from simbridge.sim.sensors import SensorSuite
from simbridge.sim.sensors.odometry import Odometry
from simbridge.sim.world.world import World

__all__ = [
    "DEMOS",
    "RvizTarget",
    "demo_config_path",
    "resolve_target",
    "rviz_command",
    "rviz_config",
]

DEMOS: dict[str, Path] = {
    "mobile-robot": MOBILE_ROBOT_SCENE,
    "pick-and-place": PICK_AND_PLACE_SCENE,
}
"""Demo name -> its scene; the shipped config lies next to it as `<demo>.rviz`."""

_CAMERA_SKIP = ("/compressed", "/depth/image_raw")
"""Image topics not shown: the compressed copy and the millimetre copy of the depth."""


def demo_config_path(demo: str) -> Path:
    """The shipped RViz config of `demo`."""
    return DEMOS[demo].parent / f"{demo.replace('-', '_')}.rviz"


def _display(cls: str, name: str, **props: Any) -> dict[str, Any]:
    return {"Class": f"rviz/{cls}", "Enabled": True, "Name": name, "Value": True, **props}


def _frame_prefix(spec_prefix: str, ros_prefix: str | None) -> str:
    """RViz's RobotModel `TF Prefix` (joined to link names with '/')."""
    prefix = ros_prefix if ros_prefix is not None else spec_prefix
    return prefix.rstrip("/") if prefix.endswith("/") else ""


def rviz_config(scene: Scene | str | Path) -> str:
    """The RViz config (YAML) showing what `scene` publishes through `simbridge sim`."""
    scene = scene if isinstance(scene, Scene) else load_scene(scene)
    world = World.from_scene(scene)
    displays: list[dict[str, Any]] = []
    fixed = WORLD_FRAME
    bases = [robot.base.xyz for robot in scene.robots] or [(0.0, 0.0, 0.0)]
    focus = [round(sum(axis) / len(bases), 3) for axis in zip(*bases, strict=True)]
    displays.append(
        _display("Grid", "Grid", **{"Reference Frame": "<Fixed Frame>", "Cell Size": 0.5})
    )
    params = description_params(world)
    for (param, _text), robot in zip(params.items(), world.robots.values(), strict=True):
        ros = robot.built.spec.ros
        prefix = _frame_prefix(robot.prefix, ros.frame_prefix if ros is not None else None)
        displays.append(
            _display(
                "RobotModel",
                f"RobotModel {robot.name}",
                Alpha=1,
                **{
                    "Robot Description": param,
                    "TF Prefix": prefix,
                    "Visual Enabled": True,
                    "Collision Enabled": False,
                    "Update Interval": 0,
                },
            )
        )
    displays.append(
        _display(
            "TF",
            "TF",
            **{"Show Names": False, "Show Axes": True, "Show Arrows": False, "Marker Scale": 0.25},
        )
    )
    if scene.sensors:
        suite = SensorSuite.from_config(world.model, scene.sensors)
        for sensor in suite.sensors:
            if isinstance(sensor, Odometry) and sensor.config.publish_tf:
                fixed = sensor.frame_id
        try:
            for topic, msg_type in suite.outputs.items():
                displays.extend(_sensor_display(topic, msg_type))
        finally:
            suite.close()
    config = {
        "Panels": [
            {"Class": "rviz/Displays", "Name": "Displays"},
            {"Class": "rviz/Views", "Name": "Views"},
        ],
        "Visualization Manager": {
            "Class": "",
            "Displays": displays,
            "Enabled": True,
            "Global Options": {
                "Background Color": "48; 48; 48",
                "Fixed Frame": fixed,
                "Frame Rate": 30,
            },
            "Name": "root",
            "Tools": [{"Class": "rviz/Interact"}, {"Class": "rviz/MoveCamera"}],
            "Value": True,
            "Views": {
                "Current": {
                    "Class": "rviz/Orbit",
                    "Distance": 2.0,
                    "Focal Point": {"X": focus[0], "Y": focus[1], "Z": focus[2] + 0.15},
                    "Name": "Current View",
                    "Pitch": 0.6,
                    "Target Frame": "<Fixed Frame>",
                    "Yaw": 3.6,
                },
                "Saved": None,
            },
        },
        "Window Geometry": {"Height": 720, "Width": 1280, "X": 0, "Y": 0},
    }
    header = "# RViz (ROS 1) config written by simbridge.apps.rviz.rviz_config; see README (RViz)\n"
    return header + yaml.safe_dump(config, sort_keys=False, default_flow_style=False)


def _sensor_display(topic: str, msg_type: str) -> list[dict[str, Any]]:
    if msg_type == "sensor_msgs/LaserScan":
        return [
            _display(
                "LaserScan",
                f"LaserScan {topic}",
                Topic=topic,
                Style="Flat Squares",
                **{
                    "Size (m)": 0.04,
                    "Color Transformer": "FlatColor",
                    "Color": "255; 40; 40",
                    "Queue Size": 10,
                },
            )
        ]
    if msg_type == "sensor_msgs/PointCloud2":
        return [
            _display(
                "PointCloud2",
                f"PointCloud2 {topic}",
                Topic=topic,
                Style="Points",
                **{"Size (Pixels)": 3, "Color Transformer": "AxisColor", "Axis": "Z"},
            )
        ]
    if msg_type == "sensor_msgs/Image" and not topic.endswith(_CAMERA_SKIP):
        return [
            _display(
                "Image",
                f"Image {topic}",
                **{"Image Topic": topic, "Transport Hint": "raw", "Queue Size": 2},
            )
        ]
    if msg_type == "nav_msgs/Odometry":
        shape = {
            "Value": "Arrow",
            "Color": "255; 170; 0",
            "Alpha": 1,
            "Shaft Length": 0.25,
            "Shaft Radius": 0.01,
            "Head Length": 0.06,
            "Head Radius": 0.03,
        }
        return [
            _display(
                "Odometry",
                f"Odometry {topic}",
                Topic=topic,
                Keep=20,
                Shape=shape,
                **{"Position Tolerance": 0.1, "Angle Tolerance": 0.2},
            )
        ]
    return []


@dataclass(frozen=True)
class RvizTarget:
    """What `simbridge rviz` shows: a config file (shipped or written for a scene)."""

    config: Path
    scene: Path


def resolve_target(target: str, write_dir: Path) -> RvizTarget:
    """A demo name (its shipped config) or a scene file (a config written into
    `write_dir`)."""
    if target in DEMOS:
        return RvizTarget(demo_config_path(target), DEMOS[target])
    path = Path(target)
    if not path.is_file():
        raise AppError(
            f"{target!r} is neither a demo ({', '.join(DEMOS)}) nor a scene file that exists"
        )
    config = write_dir / f"{path.stem}.rviz"
    config.write_text(rviz_config(path))
    return RvizTarget(config, path)


def rviz_command(config: Path, env: dict[str, str] | None = None) -> list[str]:
    """`rviz -d CONFIG`, after checking that rviz is installed and a display is set (an
    X server: a desktop, `ssh -X` or `Xvfb`)."""
    env = dict(os.environ) if env is None else env
    rviz = shutil.which("rviz", path=env.get("PATH"))
    if rviz is None:
        raise AppError(
            "rviz is not installed (Debian: apt-get install rviz; `make sysdeps` installs it)"
        )
    if not env.get("DISPLAY") and not env.get("WAYLAND_DISPLAY"):
        raise AppError(
            "no display: DISPLAY is not set; RViz needs an X server (a desktop session, "
            "ssh -X, or a virtual one: xvfb-run -a simbridge rviz ...)"
        )
    return [rviz, "-d", str(config)]
