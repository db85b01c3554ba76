"""Scene files with mistakes: each error names the file, the line, the entry, what was
expected, and the closest valid key or name."""

from __future__ import annotations

import pickle
from pathlib import Path

import pytest

from simbridge.errors import SimError, did_you_mean
from simbridge.sim.scene import Scene, build_scene, load_scene, parse_scene
from simbridge.sim.scene.located import read_yaml
from tests.sim.urdf_samples import GRAVITY_ARM

CASES = [
    (
        "physics: {timestep: 0.002}\nsensor: []\n",
        r"s\.yaml:2: top level: unknown key 'sensor'; did you mean 'sensors'\?",
    ),
    (
        "robots:\n  - urdf: arm.urdf\n    initial_position: {elbow: 1}\n",
        r"s\.yaml:3: robots\[0\]: unknown key 'initial_position'; "
        r"did you mean 'initial_positions'\?",
    ),
    (
        "sensors:\n"
        "  - {type: imu, name: imu, body: base}\n"
        "  - type: lidar_2d\n"
        "    name: front\n"
        "    body: base\n"
        "    rang_max: 3\n",
        r"s\.yaml:6: sensors\[1\] \(lidar_2d 'front'\): unknown option 'rang_max'; "
        r"did you mean 'range_max'\? \(valid: .*range_max",
    ),
    (
        "sensors:\n  - name: cam\n    type: camera\n    body: base\n    widht: 64\n",
        r"s\.yaml:5: sensors\[0\] \(camera 'cam'\): unknown option 'widht'; "
        r"did you mean 'width'\?",
    ),
    (
        "sensors:\n  - name: cam\n    type: camera\n    body: base\n    width: wide\n",
        r"s\.yaml:5: sensors\[0\] \(camera 'cam'\): width: must be an integer, got 'wide'",
    ),
    (
        "sensors:\n  - name: front\n    type: lidar2d\n",
        r"s\.yaml:3: sensors\[0\]\.type: unknown sensor type 'lidar2d'; "
        r"did you mean 'lidar_2d'\? \(valid: lidar_2d, lidar_3d, camera",
    ),
    (
        "sensors:\n  - {type: imu, name: imu}\n",
        r"s\.yaml:2: sensors\[0\] \(imu 'imu'\): missing required option 'body'",
    ),
    (
        "sensors:\n  - {name: imu, body: base}\n",
        r"s\.yaml:2: sensors\[0\]: a sensor needs a 'type' \(one of lidar_2d",
    ),
    (
        "sensors:\n  - {type: imu, name: a, body: base}\n  - {type: imu, name: a, body: base}\n",
        r"s\.yaml:3: sensors\[1\]\.name: the name 'a' is already taken by sensors\[0\]",
    ),
    (
        "physics:\n  integrator: implict\n",
        r"s\.yaml:2: physics\.integrator: unknown integrator 'implict'; "
        r"did you mean 'implicit'\?",
    ),
    (
        "objects:\n  - name: floor\n    type: plane\n  - name: box\n    type: boxx\n",
        r"s\.yaml:5: objects\[1\]\.type: unknown shape 'boxx'; did you mean 'box'\?",
    ),
    (
        "objects:\n  - name: b\n    type: box\n    size: [1, 1, -1]\n",
        r"s\.yaml:4: objects\[0\]\.size\[2\]: must be > 0, got -1",
    ),
    ("robots: {urdf: arm.urdf}\n", r"s\.yaml:1: robots: expected a list of entries, got a mapping"),
    ("- 1\n- 2\n", r"s\.yaml: top level: expected a mapping of keys, got a list"),
    ("physics:\n  timestep: 0.002\n gravity: [0, 0, -9.8]\n", r"s\.yaml:3:2: not valid YAML"),
    ("robots: [\n", r"s\.yaml:2:1: not valid YAML"),
]


@pytest.mark.parametrize(("text", "message"), CASES)
def test_a_scene_error_points_at_the_line(tmp_path: Path, text: str, message: str) -> None:
    (tmp_path / "arm.urdf").write_text(GRAVITY_ARM)
    (tmp_path / "s.yaml").write_text(text)
    with pytest.raises(SimError, match=message):
        load_scene(tmp_path / "s.yaml")


def test_a_sensor_on_a_body_that_is_not_there_fails_when_the_scene_is_built(
    tmp_path: Path,
) -> None:
    (tmp_path / "arm.urdf").write_text(GRAVITY_ARM)
    (tmp_path / "s.yaml").write_text(
        "robots:\n  - urdf: arm.urdf\nsensors:\n  - type: imu\n    name: imu\n    body: uper\n"
    )
    scene = load_scene(tmp_path / "s.yaml")  # the model's bodies are known once built
    expected = (
        r"s\.yaml:6: sensors\[0\] \(imu 'imu'\)\.body: no body 'uper' in the scene; "
        r"did you mean 'upper'\? \(bodies: .*world\)"
    )
    with pytest.raises(SimError, match=expected):
        build_scene(scene)
    good = load_scene_text(tmp_path, "sensors:\n  - {type: imu, name: imu, body: world}\n")
    build_scene(good)


def load_scene_text(tmp_path: Path, text: str) -> Scene:
    (tmp_path / "t.yaml").write_text(text)
    return load_scene(tmp_path / "t.yaml")


def test_scenes_from_python_data_name_the_entry_without_a_file(tmp_path: Path) -> None:
    with pytest.raises(SimError, match=r"^scene sensors\[0\] \(imu 'i'\): unknown option 'bdy'"):
        parse_scene({"sensors": [{"type": "imu", "name": "i", "bdy": "x"}]}, tmp_path)


def test_a_loaded_scene_holds_plain_data_and_pickles(tmp_path: Path) -> None:
    scene = load_scene_text(
        tmp_path, "sensors:\n  - {type: lidar_2d, name: l, body: world, xyz: [0, 0, 1]}\n"
    )
    (entry,) = scene.sensors
    assert type(entry) is dict
    assert type(entry["xyz"]) is list
    assert pickle.loads(pickle.dumps(scene)).sensors == scene.sensors


def test_yaml_keeps_the_line_of_every_key_and_item(tmp_path: Path) -> None:
    (tmp_path / "x.yaml").write_text("a: 1\nb:\n  - x\n  - c: 2\n")
    data = read_yaml(tmp_path / "x.yaml")
    assert data == {"a": 1, "b": ["x", {"c": 2}]}
    assert data.key_lines == {"a": 1, "b": 2}  # type: ignore[attr-defined]
    assert data["b"].item_lines == [3, 4]  # type: ignore[index]


def test_did_you_mean_names_only_a_close_choice() -> None:
    assert did_you_mean("rang_max", ["range_min", "range_max", "samples"]) == (
        "; did you mean 'range_max'?"
    )
    assert did_you_mean("IMU", ["imu", "camera"]) == "; did you mean 'imu'?"
    assert did_you_mean("sonar", ["imu", "camera"]) == ""
