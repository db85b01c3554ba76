"""`/robot_description` from the URDF the sim loaded: meshes as absolute file:// URIs of
the files the sim found (what RViz needs), the rest of the text as written; one
parameter per robot, in the robot's namespace."""

from __future__ import annotations

import warnings
from pathlib import Path
from urllib.parse import unquote, urlparse

import yaml

from simbridge.sim.ros import description_params
from simbridge.sim.scene import load_scene
from simbridge.sim.urdf import load_urdf
from simbridge.sim.urdf.description import robot_description
from simbridge.sim.world import World
from tests.sim.mesh_samples import ascii_stl
from tests.sim.urdf_samples import GRAVITY_ARM

URDF = """<?xml version="1.0"?>
<!-- a comment that stays -->
<robot name="meshy">
  <link name="base">
    <visual><geometry><mesh filename="package://my robot/meshes/body.stl" scale="1 1 1"/>
    </geometry></visual>
    <collision><geometry><mesh filename='../meshes/body.stl'/></geometry></collision>
  </link>
  <link name="tip">
    <visual><geometry><mesh filename="package://my robot/meshes/missing.stl"/></geometry>
    </visual>
    <visual><geometry><box size="0.1 0.1 0.1"/></geometry></visual>
  </link>
  <joint name="j" type="fixed"><parent link="base"/><child link="tip"/></joint>
</robot>
"""


def test_meshes_become_absolute_file_uris(tmp_path: Path) -> None:
    package = tmp_path / "my robot"  # a space: the URI must be percent-encoded
    (package / "urdf").mkdir(parents=True)
    (package / "meshes").mkdir()
    ascii_stl(package / "meshes" / "body.stl")
    (package / "urdf" / "r.urdf").write_text(URDF)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the missing mesh
        robot = load_urdf(package / "urdf" / "r.urdf")
    text = robot_description(robot)
    uri = (package / "meshes" / "body.stl").resolve().as_uri()
    assert "%20" in uri
    assert text.count(f'filename="{uri}"') == 2  # package:// and relative alike
    assert Path(unquote(urlparse(uri).path)).is_file()
    assert 'filename="package://my robot/meshes/missing.stl"' in text  # kept as written
    assert "<!-- a comment that stays -->" in text
    assert text.replace(uri, "X") == URDF.replace(
        'filename="package://my robot/meshes/body.stl"', 'filename="X"'
    ).replace("filename='../meshes/body.stl'", 'filename="X"')


def _scene(tmp_path: Path, robots: list[dict[str, object]]) -> World:
    (tmp_path / "arm.urdf").write_text(GRAVITY_ARM)
    (tmp_path / "scene.yaml").write_text(yaml.safe_dump({"robots": robots}))
    return World.from_scene(load_scene(tmp_path / "scene.yaml"))


def test_one_parameter_per_robot_in_its_namespace(tmp_path: Path) -> None:
    one = _scene(tmp_path, [{"urdf": "arm.urdf"}])
    assert list(description_params(one)) == ["/robot_description"]
    assert description_params(one)["/robot_description"] == GRAVITY_ARM
    namespaced = _scene(
        tmp_path,
        [
            {"urdf": "arm.urdf", "name": "left", "ros": {"namespace": "/arm_left"}},
            {"urdf": "arm.urdf", "name": "right", "ros": {"namespace": "/arm_right"}},
        ],
    )
    assert sorted(description_params(namespaced)) == [
        "/arm_left/robot_description",
        "/arm_right/robot_description",
    ]
    plain_two = _scene(
        tmp_path,
        [
            {"urdf": "arm.urdf", "name": "a", "base": {"xyz": [0, 1, 0]}, "prefix": "a_"},
            {"urdf": "arm.urdf", "name": "b", "prefix": "b_"},
        ],
    )
    assert sorted(description_params(plain_two)) == ["/a/robot_description", "/b/robot_description"]
