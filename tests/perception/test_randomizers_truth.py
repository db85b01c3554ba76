"""Scene randomisers checked against their documented contracts (docs/perception.md) from
the sim's own state after each frame is posed (MuJoCo model and data, the camera views),
over several seeds and frames: placement, robot joints, camera pose and intrinsics,
lights, and mesh distractors from a folder."""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path

import mujoco
import numpy as np
import pytest
from numpy.typing import NDArray

from simbridge.perception import FrameMaker

ROBOT_URDF = (
    Path(__file__).parents[2] / "src" / "simbridge" / "assets" / "robots" / "niryo_one.urdf"
)
WIDTH, HEIGHT, FOVY = 160, 120, 55.0
AREA = (0.6, 0.8)
YAW = (-90.0, 90.0)
TARGET, JITTER = np.array([0.1, 0.0, 0.05]), np.array([0.05, 0.05, 0.02])
DISTANCE, AZIMUTH, ELEVATION = (0.9, 1.3), (-60.0, 60.0), (30.0, 60.0)
FOCAL, PRINCIPAL = (0.95, 1.05), (-2.0, 2.0)
LIGHT_COUNT, INTENSITY, TINT, AMBIENT = (1, 3), (0.4, 0.8), (0.9, 1.0), (0.05, 0.1)
LIGHT_CENTER, LIGHT_SIZE = np.array([0.0, 0.0, 1.8]), np.array([2.0, 2.0, 0.6])
LIGHT_TARGET, LIGHT_JITTER = np.array([0.1, -0.1, 0.0]), np.array([0.3, 0.2, 0.0])
ROBOT_SHARE = 0.6
SEEDS = (0, 1, 2, 3)
FRAMES = range(5)
PLACED = ("cube_0", "cube_1", "can")
EPS = 1e-6


def _scene(folder: Path, *, shadows: float) -> Path:
    """The randomised scene; `shadows` is also the lights' directional share (0 or 1)."""
    text = f"""\
ros: {{enabled: false}}
robots:
  - {{name: niryo_one, urdf: {ROBOT_URDF}, label: robot,
     initial_positions: {{left_finger_joint: 0.035}}}}
objects:
  - {{name: table, type: box, size: [0.8, 1.0, 0.04], pose: {{xyz: [0, 0, -0.02]}}}}
  - {{name: cube_0, type: box, size: [0.06, 0.06, 0.06], dynamic: true, label: cube,
     pose: {{xyz: [0.1, 0.1, 0.03]}}}}
  - {{name: cube_1, type: box, size: [0.05, 0.08, 0.04], dynamic: true, label: cube,
     pose: {{xyz: [-0.1, 0.1, 0.02]}}}}
  - {{name: can, type: cylinder, size: [0.03, 0.1], dynamic: true, label: can,
     pose: {{xyz: [0.0, -0.15, 0.05]}}}}
lights:
  - {{type: directional, pos: [0, 0, 2], dir: [0.2, 0.3, -1]}}
perception:
  classes: [cube, can, robot, distractor]
  cameras:
    - {{name: main, width: {WIDTH}, height: {HEIGHT}, fovy: {FOVY}, eye: [1.0, 0.5, 0.7],
       target: [0, 0, 0]}}
  randomizers:
    - {{type: robot_joints, robot: niryo_one, range: {ROBOT_SHARE}}}
    - {{type: placement, objects: [cube_*, can], surface: table, area: {list(AREA)},
       yaw: {list(YAW)}}}
    - {{type: distractors, count: [1, 4], surface: table, area: {list(AREA)}, yaw: {list(YAW)},
       size: [0.02, 0.06], label: distractor}}
    - {{type: lights, count: {list(LIGHT_COUNT)}, region: {{center: {LIGHT_CENTER.tolist()},
       size: {LIGHT_SIZE.tolist()}}}, intensity: {list(INTENSITY)}, tint: {list(TINT)},
       ambient: {list(AMBIENT)}, shadows: {shadows}, directional: {shadows},
       target: {LIGHT_TARGET.tolist()}, target_jitter: {LIGHT_JITTER.tolist()}}}
    - {{type: camera, camera: main, target: {TARGET.tolist()}, target_jitter: {JITTER.tolist()},
       distance: {list(DISTANCE)}, azimuth: {list(AZIMUTH)}, elevation: {list(ELEVATION)}}}
    - {{type: intrinsics, focal: {list(FOCAL)}, principal: {list(PRINCIPAL)}}}
"""
    path = folder / "randomised.yaml"
    path.write_text(text)
    return path


@pytest.fixture(scope="module", params=[0.0, 1.0], ids=["no_shadows", "shadows"])
def makers(
    tmp_path_factory: pytest.TempPathFactory, request: pytest.FixtureRequest
) -> Iterator[tuple[float, list[FrameMaker]]]:
    """One frame maker per seed on the randomised scene, lights declared with `shadows`."""
    scene = _scene(tmp_path_factory.mktemp("randomised"), shadows=request.param)
    built = [FrameMaker(scene, seed=seed) for seed in SEEDS]
    try:
        yield request.param, built
    finally:
        for maker in built:
            maker.close()


def _world_points(model: mujoco.MjModel, data: mujoco.MjData, geom: int) -> NDArray[np.float64]:
    """The world corners of a geom's bounding box (a mesh: its vertices)."""
    kind = int(model.geom_type[geom])
    size = model.geom_size[geom]
    if kind == int(mujoco.mjtGeom.mjGEOM_MESH):
        mesh = int(model.geom_dataid[geom])
        start, count = int(model.mesh_vertadr[mesh]), int(model.mesh_vertnum[mesh])
        local = np.asarray(model.mesh_vert[start : start + count], dtype=np.float64)
    else:
        half = {
            int(mujoco.mjtGeom.mjGEOM_BOX): size,
            int(mujoco.mjtGeom.mjGEOM_ELLIPSOID): size,
            int(mujoco.mjtGeom.mjGEOM_SPHERE): (size[0], size[0], size[0]),
            int(mujoco.mjtGeom.mjGEOM_CYLINDER): (size[0], size[0], size[1]),
            int(mujoco.mjtGeom.mjGEOM_CAPSULE): (size[0], size[0], size[1] + size[0]),
        }[kind]
        signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])
        local = signs * np.asarray(half, dtype=np.float64)
    rotation = data.geom_xmat[geom].reshape(3, 3)
    return np.asarray(data.geom_xpos[geom] + local @ rotation.T, dtype=np.float64)


def _on_table(maker: FrameMaker) -> dict[str, int]:
    """Name -> geom of every drawn placed object and distractor (hidden ones left out)."""
    model = maker.world.model
    found = {}
    for geom in range(model.ngeom):
        body = model.body(int(model.geom_bodyid[geom])).name
        placed = body in PLACED or body.startswith("perception/distractor_")
        if placed and int(model.geom_group[geom]) < 3:
            found[body] = geom
    return found


def test_placement_stands_on_the_table_apart_within_area_and_yaw(
    makers: tuple[float, list[FrameMaker]],
) -> None:
    _, built = makers
    placed_objects = 0
    for maker in built:
        for index in FRAMES:
            maker.pose(index)
            model, data = maker.world.model, maker.world.data
            circles = []
            for name, geom in _on_table(maker).items():
                points = _world_points(model, data, geom)
                assert abs(points[:, 2].min()) < EPS, f"{name} bottom at {points[:, 2].min()}"
                centre = data.xpos[model.body(name).id][:2]
                radius = float(np.max(np.hypot(*(points[:, :2] - centre).T)))
                for axis, half in enumerate(np.array(AREA) / 2):
                    assert abs(centre[axis]) + radius <= half + EPS, (name, centre, radius)
                rotation = data.xmat[model.body(name).id].reshape(3, 3)
                assert rotation[2, 2] == pytest.approx(1.0, abs=EPS), f"{name} tilted"
                yaw = math.degrees(math.atan2(rotation[1, 0], rotation[0, 0]))
                assert YAW[0] - EPS <= yaw <= YAW[1] + EPS, f"{name} yaw {yaw}"
                circles.append((name, centre, radius))
                placed_objects += name in PLACED
            for i, (a, ca, ra) in enumerate(circles):
                for b, cb, rb in circles[i + 1 :]:
                    gap = float(np.linalg.norm(ca - cb)) - ra - rb
                    assert gap >= -EPS, f"{a} and {b} footprints overlap by {-gap} m"
    assert placed_objects >= len(PLACED) * len(built) * len(FRAMES) // 2


def test_robot_joints_within_the_declared_share_of_their_limits(
    makers: tuple[float, list[FrameMaker]],
) -> None:
    _, built = makers
    seen: list[float] = []
    for maker in built:
        robot = maker.world.robots["niryo_one"]
        for index in FRAMES:
            maker.pose(index)
            positions = maker.world.joint_positions(robot.driven_joints)
            for name, value in positions.items():
                limit = robot.joints[name].joint.limit
                assert limit is not None
                middle, half = (limit.lower + limit.upper) / 2, (limit.upper - limit.lower) / 2
                assert abs(value - middle) <= half * ROBOT_SHARE + EPS, (name, value, limit)
                seen.append(value)
    assert len(set(seen)) > len(seen) // 2, "joint values do not vary"


def _ray_meets_box(eye: NDArray[np.float64], axis: NDArray[np.float64]) -> tuple[float, float]:
    """The ray parameters (m along `axis` from `eye`) inside the target's jitter box."""
    low, high = -math.inf, math.inf
    for k in range(3):
        a, b = TARGET[k] - JITTER[k] - eye[k], TARGET[k] + JITTER[k] - eye[k]
        if abs(axis[k]) < 1e-12:
            assert a <= EPS
            assert b >= -EPS
            continue
        t0, t1 = sorted((a / axis[k], b / axis[k]))
        low, high = max(low, t0), min(high, t1)
    return low, high


def test_camera_looks_at_the_target_from_the_declared_ranges(
    makers: tuple[float, list[FrameMaker]],
) -> None:
    _, built = makers
    fy0 = (HEIGHT / 2) / math.tan(math.radians(FOVY) / 2)
    for maker in built:
        for index in FRAMES:
            view = maker.pose(index).views["main"]
            axis = view.rotation[:, 2]
            low, high = _ray_meets_box(view.position, axis)
            low, high = max(low, DISTANCE[0]), min(high, DISTANCE[1])
            assert low <= high + EPS, f"frame {index}: optical axis misses the target box"
            elevation = math.degrees(math.asin(-axis[2]))
            azimuth = math.degrees(math.atan2(-axis[1], -axis[0]))
            assert ELEVATION[0] - EPS <= elevation <= ELEVATION[1] + EPS, elevation
            assert AZIMUTH[0] - EPS <= azimuth <= AZIMUTH[1] + EPS, azimuth
            assert abs(view.rotation[2, 0]) < EPS, "roll 0: the image x axis is level"
            assert view.rotation[2, 1] < 0, "image y points down"
            scale = view.fy / fy0
            assert FOCAL[0] - EPS <= scale <= FOCAL[1] + EPS, scale
            assert view.fx == pytest.approx(view.fy), "aspect [1, 1]"
            for shift in (view.cx - (WIDTH - 1) / 2, view.cy - (HEIGHT - 1) / 2):
                assert PRINCIPAL[0] - EPS <= shift <= PRINCIPAL[1] + EPS, shift


def test_lights_count_colour_level_place_and_shadows(
    makers: tuple[float, list[FrameMaker]],
) -> None:
    shadows, built = makers
    counts = set()
    misses: list[float] = []
    for maker in built:
        model = maker.world.model
        assert model.nlight == LIGHT_COUNT[1]
        for index in FRAMES:
            maker.pose(index)
            active = [bool(on) for on in model.light_active]
            count = sum(active)
            assert LIGHT_COUNT[0] <= count <= LIGHT_COUNT[1]
            assert active == [k < count for k in range(model.nlight)], "the first lights shine"
            counts.add(count)
            for light in range(count):
                diffuse = model.light_diffuse[light]
                assert INTENSITY[0] * TINT[0] - EPS <= diffuse.min()
                assert diffuse.max() <= INTENSITY[1] * TINT[1] + EPS
                assert diffuse.min() / diffuse.max() >= TINT[0] / TINT[1] - EPS
                ambient = model.light_ambient[light]
                assert AMBIENT[0] - EPS <= ambient.min()
                assert ambient.max() <= AMBIENT[1] + EPS
                offset = np.abs(model.light_pos[light] - LIGHT_CENTER)
                assert (offset <= LIGHT_SIZE / 2 + EPS).all(), model.light_pos[light]
                assert bool(model.light_castshadow[light]) is (shadows == 1.0)
                directional = int(model.light_type[light]) == int(
                    mujoco.mjtLightType.mjLIGHT_DIRECTIONAL
                )
                assert directional is (shadows == 1.0)
                aim = _aim_miss(model.light_pos[light], model.light_dir[light])
                assert aim <= EPS, f"light {light} aims {aim} m outside the target's jitter box"
                misses.append(
                    _distance_to_line(LIGHT_TARGET, model.light_pos[light], model.light_dir[light])
                )
    assert len(counts) > 1, f"light count never varies: {counts}"
    assert max(misses) > 0.05, "the lights never aim off the target: target_jitter unused"


def _aim_miss(position: NDArray[np.float64], direction: NDArray[np.float64]) -> float:
    """How far (m, per axis) the ray from `position` along `direction` passes outside the
    box target +- target_jitter (0 when it goes through it: slab test)."""
    low, high = LIGHT_TARGET - LIGHT_JITTER, LIGHT_TARGET + LIGHT_JITTER
    # The ray meets the box's z slab (a plane here: no z jitter) at t; x and y must fit there.
    t = (LIGHT_TARGET[2] - position[2]) / direction[2]
    assert t > 0, "the light points away from the target"
    point = position + t * direction
    return float(np.maximum(np.maximum(low - point, point - high), 0.0).max())


def _distance_to_line(
    point: NDArray[np.float64], origin: NDArray[np.float64], direction: NDArray[np.float64]
) -> float:
    offset = point - origin
    return float(np.linalg.norm(offset - offset @ direction * direction))


def _cube_obj(path: Path, half: float) -> None:
    corners = [(x, y, z) for x in (-half, half) for y in (-half, half) for z in (-half, half)]
    faces = [(1, 3, 4, 2), (5, 6, 8, 7), (1, 2, 6, 5), (3, 7, 8, 4), (1, 5, 7, 3), (2, 4, 8, 6)]
    lines = [f"v {x} {y} {z}" for x, y, z in corners]
    lines += ["f " + " ".join(str(i) for i in face) for face in faces]
    path.write_text("\n".join(lines) + "\n")


def test_mesh_distractors_from_a_folder_appear_and_render(tmp_path: Path) -> None:
    folder = tmp_path / "meshes"
    folder.mkdir()
    _cube_obj(folder / "cube.obj", 0.05)
    scale, count = 0.4, (2, 4)
    scene = tmp_path / "mesh.yaml"
    scene.write_text(f"""\
ros: {{enabled: false}}
objects:
  - {{name: floor, type: plane}}
perception:
  classes: [clutter]
  cameras:
    - {{name: main, width: {WIDTH}, height: {HEIGHT}, fovy: 60, eye: [1.2, 0, 0.8],
       target: [0, 0, 0.4]}}
  randomizers:
    - {{type: distractors, count: {list(count)}, shapes: [mesh], meshes: {folder},
       mesh_scale: {scale}, region: {{center: [0, 0, 0.4], size: [0.4, 0.4, 0.2]}},
       label: clutter}}
""")
    for seed in (0, 5):
        maker = FrameMaker(scene, seed=seed)
        try:
            model = maker.world.model
            for index in range(3):
                frame = maker.make(index)
                shown = [
                    g
                    for g in range(model.ngeom)
                    if model.body(int(model.geom_bodyid[g])).name.startswith("perception/")
                    and int(model.geom_group[g]) < 3
                ]
                assert count[0] <= len(shown) <= count[1], shown
                for geom in shown:
                    assert int(model.geom_type[geom]) == int(mujoco.mjtGeom.mjGEOM_MESH)
                    points = _world_points(model, maker.world.data, geom)
                    rotation = maker.world.data.geom_xmat[geom].reshape(3, 3)
                    local = (points - maker.world.data.geom_xpos[geom]) @ rotation
                    extent = local.max(axis=0) - local.min(axis=0)
                    assert extent == pytest.approx([0.1 * scale] * 3, abs=1e-6)
                    centre = maker.world.data.geom_xpos[geom]
                    assert (np.abs(centre - [0, 0, 0.4]) <= [0.2, 0.2, 0.1 + EPS]).all()
                view = frame.views[0]
                assert view.rgb is not None
                assert view.rgb.shape == (HEIGHT, WIDTH, 3)
                seen = [label.visible_px for label in view.labels.instances if label.visible_px > 0]
                assert seen, f"seed {seed} frame {index}: no mesh distractor drawn"
        finally:
            maker.close()
