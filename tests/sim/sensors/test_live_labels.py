"""Live labels on the local backend: a camera with labelers publishes instance and semantic
segmentation and vision_msgs/Detection2DArray next to its image; the crate's box matches
its projected corners, the ids and classes are the scene's (as a dataset of it has them),
and the segmentation images agree with the boxes. Detections come in each generation's
vision_msgs layout: noetic's on ROS 1 (int64 class id, geometry_msgs/Pose2D centre, no
instance id), 4.x on ROS 2 (class name, the instance id as the detection's id)."""

from __future__ import annotations

import queue
import time
from pathlib import Path
from typing import Any, Literal

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from simbridge.endpoint import EndpointOptions, EndpointThread, LocalBus, Node
from simbridge.errors import SimError
from simbridge.perception import FrameMaker
from simbridge.sim.labels import scene_label_table
from simbridge.sim.runner import SimulationSession
from simbridge.sim.scene import load_scene
from simbridge.sim.sensors import Camera, SensorSuite, optical_pose, sensor_config
from tests.sim.sensors.labelled_scene import (
    CAMERA_TOPIC,
    CLASSES,
    CRATE_XYZ,
    CRATE_YAW,
    HEIGHT,
    WIDTH,
    crate_pixel_box,
    labelled_scene,
)

TOPICS = {
    f"{CAMERA_TOPIC}/instances": "sensor_msgs/Image",
    f"{CAMERA_TOPIC}/semantic": "sensor_msgs/Image",
    f"{CAMERA_TOPIC}/detections": "vision_msgs/Detection2DArray",
}


def _ids(image: Any) -> np.ndarray:
    assert (image.encoding, image.is_bigendian, image.step) == ("16UC1", 0, 2 * WIDTH)
    assert (image.width, image.height) == (WIDTH, HEIGHT)
    return np.frombuffer(bytes(image.data), dtype="<u2").reshape(HEIGHT, WIDTH)


def _stamp(header: Any) -> tuple[int, int]:
    return (int(header.stamp.sec), int(header.stamp.nanosec))


INSTANCE_IDS = {"crate": 1, "ball": 2, "post": 3}
"""The scene's instance ids (objects with a label in scene order, then labels: entries)."""


def _by_class(array: Any, protocol: Literal["ROS1", "ROS2"]) -> dict[str, Any]:
    """An array's detections by class name, in the order they came (instance-id order),
    each read in its generation's layout: noetic's int64 class id and no instance id, or
    4.x's class name and the instance id as the detection's id; every score 1."""
    found = {}
    for detection in array.detections:
        (result,) = detection.results
        if protocol == "ROS1":
            assert not hasattr(detection, "id")
            assert (detection.source_img.width, detection.source_img.height) == (0, 0)
            name, score = CLASSES[result.id - 1], result.score
        else:
            name, score = result.hypothesis.class_id, result.hypothesis.score
            assert int(detection.id) == INSTANCE_IDS[name]
        assert score == 1.0
        found[name] = detection
    return found


def _centre(box: Any) -> tuple[float, float]:
    """A BoundingBox2D's centre: geometry_msgs/Pose2D (noetic) or vision_msgs/Pose2D (4.x)."""
    centre = box.center.position if hasattr(box.center, "position") else box.center
    return (centre.x, centre.y)


@pytest.mark.parametrize("protocol", ["ROS1", "ROS2"])
def test_live_labels_match_the_geometry_and_the_scene(
    tmp_path: Path, protocol: Literal["ROS1", "ROS2"]
) -> None:
    scene = labelled_scene(tmp_path)
    got: dict[str, queue.Queue[Any]] = {topic: queue.Queue() for topic in TOPICS}
    with (
        EndpointThread(EndpointOptions(port=0), LocalBus(protocol)) as endpoint,
        Node(endpoint.backend, "/labels_tester") as node,
    ):
        for topic, msg_type in TOPICS.items():
            node.subscribe(topic, msg_type, got[topic].put)
        address = f"127.0.0.1:{endpoint.port}"
        with SimulationSession(scene, address, connect_timeout=60) as session:
            sensors = session.sensors
            assert sensors is not None
            camera = sensors.suite["cam"]
            assert isinstance(camera, Camera)
            publishers = [sensors.publisher(topic) for topic in TOPICS]
            deadline = time.monotonic() + 60
            while any(p.subscriber_count != 1 for p in publishers) and time.monotonic() < deadline:
                time.sleep(0.01)
            session.run(duration=0.25)  # frames at 0, 0.1 and 0.2 s
            assert session.connector is not None
            assert session.connector.flush(60)
            frames = {topic: [got[topic].get(timeout=60) for _ in range(2)] for topic in TOPICS}
            expected = crate_pixel_box(session.world, camera)
            optical = optical_pose(camera.world_pose(session.world.data))
    instances = _ids(frames[f"{CAMERA_TOPIC}/instances"][0])
    semantic = _ids(frames[f"{CAMERA_TOPIC}/semantic"][0])
    detections = frames[f"{CAMERA_TOPIC}/detections"][0]
    # One frame: every topic carries the same stamp and the camera's optical frame.
    headers = [frames[topic][0].header for topic in TOPICS]
    assert len({_stamp(h) for h in headers}) == 1
    assert {h.frame_id for h in headers} == {"cam_optical_frame"}
    assert _stamp(frames[f"{CAMERA_TOPIC}/detections"][1].header) > _stamp(detections.header)
    # Ids are stable: the next frame of the still scene labels every pixel alike.
    assert (_ids(frames[f"{CAMERA_TOPIC}/instances"][1]) == instances).all()
    # Instance ids in scene order: objects with a label (crate, ball), then labels: entries.
    by_class = _by_class(detections, protocol)
    assert list(by_class) == list(INSTANCE_IDS)
    assert set(INSTANCE_IDS.values()) == set(np.unique(instances)) - {0}
    for name, detection in by_class.items():
        assert _stamp(detection.header) == _stamp(detections.header)
        # The segmentation agrees with the box: the instance's pixels span it exactly, and
        # they carry the instance's class id in the semantic image.
        rows, cols = np.nonzero(instances == INSTANCE_IDS[name])
        box = detection.bbox
        assert _centre(box) == ((cols.min() + cols.max()) / 2, (rows.min() + rows.max()) / 2)
        assert box.size_x == cols.max() - cols.min() + 1
        assert box.size_y == rows.max() - rows.min() + 1
        assert box.center.theta == 0.0
        assert set(np.unique(semantic[rows, cols])) == {CLASSES.index(name) + 1}
    assert set(np.unique(semantic[instances == 0])) <= {0}
    # The crate's box is its projected corners' box, within a pixel: the visible pixels'
    # centres lie inside the projection, the outermost within a pixel of its edges.
    crate = by_class["crate"].bbox
    (u, v) = _centre(crate)
    u0 = u - (crate.size_x - 1) / 2
    v0 = v - (crate.size_y - 1) / 2
    u1, v1 = u0 + crate.size_x - 1, v0 + crate.size_y - 1
    for got_edge, want in zip((u0, v0, u1, v1), expected, strict=True):
        assert abs(got_edge - want) <= 1.0, (got_edge, want)
    assert expected[0] - 1e-9 <= u0
    assert u1 <= expected[2] + 1e-9
    # Its pose is the crate's, in the optical frame (z forward): its centre, and its yaw
    # about the world's z, which the optical frame sees as its -y.
    pose = by_class["crate"].results[0].pose.pose
    centre = optical.rotation.T @ (np.array(CRATE_XYZ) - optical.position)
    position = np.array([pose.position.x, pose.position.y, pose.position.z])
    assert np.allclose(position, centre, atol=1e-9), (position, centre)
    q = pose.orientation
    crate_axes = Rotation.from_quat([q.x, q.y, q.z, q.w]).as_matrix()
    world_axes = optical.rotation @ crate_axes
    assert np.allclose(world_axes, Rotation.from_euler("z", CRATE_YAW).as_matrix(), atol=1e-9)


def test_live_ids_are_those_of_a_dataset_of_the_scene(tmp_path: Path) -> None:
    """The live camera's label table and datagen's give every instance the same id and
    class id (what the published images and detections carry), a labelled robot's too."""
    scene = labelled_scene(tmp_path, ros=False, arm=True)
    with SimulationSession(scene) as session:
        bodies = {n: list(r.bodies.values()) for n, r in session.world.robots.items()}
        live = scene_label_table(session.world.model, session.world.scene, bodies)
    maker = FrameMaker(scene)
    try:
        datagen = maker.table
    finally:
        maker.close()
    rows = [(i.id, i.name, i.category, i.category_id) for i in live.instances]
    assert rows == [(i.id, i.name, i.category, i.category_id) for i in datagen.instances]
    assert rows == [
        (1, "crate", "crate", 2),
        (2, "ball", "ball", 1),
        (3, "arm", "arm", 4),
        (4, "pillar", "post", 3),
    ]
    assert live.categories == datagen.categories == (*CLASSES, "arm")
    assert live.by_name["arm"].bodies == datagen.by_name["arm"].bodies
    assert len(live.by_name["arm"].bodies) > 1


def test_live_labels_are_those_of_datagen_for_the_same_view(tmp_path: Path) -> None:
    """The scene's dataset camera has the live camera's view: datagen's instance and
    semantic images of frame 0 equal the live ones pixel for pixel, and its tight boxes
    the live detections'."""
    scene = labelled_scene(tmp_path)
    live = _labels_of(scene)
    maker = FrameMaker(scene)
    try:
        (view,) = maker.make(0).views
    finally:
        maker.close()
    labels = view.labels
    assert labels.instance_image is not None
    assert labels.category_image is not None
    assert set(np.unique(labels.instance_image)) == {0, 1, 2, 3}
    assert (live[f"{CAMERA_TOPIC}/instances"] == labels.instance_image).all()
    assert (live[f"{CAMERA_TOPIC}/semantic"] == labels.category_image).all()
    found = _by_class(live[f"{CAMERA_TOPIC}/detections"], "ROS1")  # the sensors' own layout
    tight = {i.instance.category: i.tight_box for i in labels.instances if i.tight_box is not None}
    assert set(found) == set(tight)
    for name, (u0, v0, u1, v1) in tight.items():
        box = found[name].bbox
        assert _centre(box) == ((u0 + u1) / 2, (v0 + v1) / 2)
        assert (box.size_x, box.size_y) == (u1 - u0 + 1, v1 - v0 + 1)


def _labels_of(scene: Path) -> dict[str, Any]:
    """The label outputs of the scene's camera measured once, outside any ROS session:
    the images' ids as arrays, the detections as the message."""
    with SimulationSession(scene) as session:
        world = session.world
        suite = SensorSuite.from_config(world.model, world.scene.sensors)
        try:
            camera = suite["cam"]
            assert isinstance(camera, Camera)
            bodies = {n: list(r.bodies.values()) for n, r in world.robots.items()}
            camera.bind_labels(scene_label_table(world.model, world.scene, bodies))
            world.refresh()
            return {
                pub.topic: _ids(pub.message) if pub.msgtype == "sensor_msgs/Image" else pub.message
                for pub in camera.measure(world.model, world.data)
                if pub.topic in TOPICS
            }
        finally:
            suite.close()


def test_labels_of_an_antialiased_camera_are_exact(tmp_path: Path) -> None:
    """A camera rendering its image with MSAA labels with the same ids, pixel for pixel,
    as one without (MuJoCo draws segmentation without multisampling; blended edges would
    mix ids)."""
    (tmp_path / "msaa").mkdir()
    plain = _labels_of(labelled_scene(tmp_path))
    smooth = _labels_of(labelled_scene(tmp_path / "msaa", multisamples=4))
    for topic in (f"{CAMERA_TOPIC}/instances", f"{CAMERA_TOPIC}/semantic"):
        assert set(np.unique(plain[topic])) == {0, 1, 2, 3}
        assert (smooth[topic] == plain[topic]).all(), topic


def test_labels_need_the_scene(tmp_path: Path) -> None:
    """A labelling camera whose scene labels were never bound says so when it is asked
    for labels (its image still works)."""
    with SimulationSession(labelled_scene(tmp_path, ros=False)) as session:
        world = session.world
        suite = SensorSuite.from_config(world.model, world.scene.sensors)
        try:
            camera = suite["cam"]
            world.refresh()
            camera.set_all_wanted(False)
            camera.set_wanted(f"{CAMERA_TOPIC}/image_raw", True)
            assert len(camera.measure(world.model, world.data)) == 1
            camera.set_wanted(f"{CAMERA_TOPIC}/detections", True)
            with pytest.raises(SimError, match=r"camera .cam. has labelers .* no scene labels"):
                camera.measure(world.model, world.data)
        finally:
            suite.close()


def test_unknown_labeler_is_named_with_its_line(tmp_path: Path) -> None:
    scene = labelled_scene(tmp_path).read_text().replace("boxes_2d]", "boxes2d]")
    (tmp_path / "bad.yaml").write_text(scene)
    with pytest.raises(SimError, match=r"bad\.yaml:\d+: .*unknown labeler 'boxes2d'.*boxes_2d"):
        load_scene(tmp_path / "bad.yaml")
    with pytest.raises(SimError, match="labelers: listed twice"):
        sensor_config({"type": "camera", "name": "c", "body": "", "labelers": ["instance"] * 2})
