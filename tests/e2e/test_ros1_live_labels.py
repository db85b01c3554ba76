"""Live labels through `simbridge endpoint --backend ros1` to a real rospy subscriber (on
a roscore of the module's own): the camera's vision_msgs/Detection2DArray, whose Python
module genpy generates from the shipped definitions (`simbridge msg genpy`) with noetic's
md5sum (so a node built against the real noetic vision_msgs connects too), in noetic's
layout, and its instance segmentation, as rospy decodes them."""

from __future__ import annotations

import json
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from tests.ros1support import SYSTEM_PYTHON, DrainedProcess, EndpointProcess, RosMaster, terminate
from tests.sim.sensors.labelled_scene import (
    CAMERA_TOPIC,
    HEIGHT,
    WIDTH,
    crate_pixel_box,
    labelled_scene,
)

from simbridge.endpoint.backends.ros1 import generate_python_messages
from simbridge.messages import default_registry
from simbridge.sim.runner import SimulationSession
from simbridge.sim.sensors import Camera

pytestmark = [pytest.mark.ros1, pytest.mark.timeout(180)]

NOETIC_DETECTION2DARRAY_MD5 = "402071f61477de256df9f1aa45e6e4c8"
"""Of noetic's vision_msgs (0.0.2) Detection2DArray; see tests/messages/test_vision_msgs.py."""

SUBSCRIBER = r"""
import json, sys, threading
import rospy
from sensor_msgs.msg import Image
from vision_msgs.msg import Detection2DArray

got = {}
done = threading.Event()

def keep(key, to_json):
    def callback(msg):
        if key not in got:
            got[key] = to_json(msg)
            if len(got) == 2:
                done.set()
    return callback

def detections(msg):
    return {
        "seq": msg.header.seq, "frame_id": msg.header.frame_id,
        "detections": [
            {"class_id": d.results[0].id, "score": d.results[0].score,
             "center": [d.bbox.center.x, d.bbox.center.y, d.bbox.center.theta],
             "size": [d.bbox.size_x, d.bbox.size_y],
             "source_img": [d.source_img.width, d.source_img.height]}
            for d in msg.detections
        ],
    }

def image(msg):
    return {"encoding": msg.encoding, "width": msg.width, "height": msg.height,
            "data": bytes(msg.data).hex()}

rospy.init_node("live_labels_listener")
rospy.Subscriber(sys.argv[1] + "/detections", Detection2DArray, keep("detections", detections))
rospy.Subscriber(sys.argv[1] + "/instances", Image, keep("instances", image))
print(json.dumps({"ready": True, "md5": Detection2DArray._md5sum}), flush=True)
done.wait(120)
print(json.dumps(got), flush=True)
"""


def _json_line(process: DrainedProcess, key: str, timeout: float) -> object:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        for line in process.output()[0].splitlines():
            if line.startswith("{") and key in json.loads(line):
                return json.loads(line)[key]
        if process.poll() is not None and key not in process.output()[0]:
            break
        time.sleep(0.05)
    raise AssertionError(f"no {key!r} from the rospy node; output: {process.output()}")


def test_rospy_receives_detections_and_segmentation(master: RosMaster, tmp_path: Path) -> None:
    modules = generate_python_messages(
        default_registry(), [], tmp_path / "genpy", ["vision_msgs/Detection2DArray"]
    )
    env = dict(master.env)
    env["PYTHONPATH"] = f"{modules['PYTHONPATH']}:{env.get('PYTHONPATH', '')}"
    script = tmp_path / "listener.py"
    script.write_text(SUBSCRIBER)
    endpoint = EndpointProcess(master, "/labels_endpoint")
    listener = DrainedProcess([SYSTEM_PYTHON, str(script), CAMERA_TOPIC], env)
    try:
        assert _json_line(listener, "ready", 60) is True
        assert _json_line(listener, "md5", 10) == NOETIC_DETECTION2DARRAY_MD5
        address = f"127.0.0.1:{endpoint.port}"
        with SimulationSession(labelled_scene(tmp_path), address, connect_timeout=10) as session:
            assert session.sensors is not None
            camera = session.sensors.suite["cam"]
            assert isinstance(camera, Camera)
            expected = crate_pixel_box(session.world, camera)
            runner = threading.Thread(target=session.run, kwargs={"realtime_factor": 1.0})
            runner.start()
            try:
                array = _json_line(listener, "detections", 90)
                image = _json_line(listener, "instances", 10)
            finally:
                session.world.stop()
                runner.join(10)
    finally:
        terminate(listener)
        endpoint.stop()
    assert isinstance(array, dict)
    assert isinstance(image, dict)
    assert array["frame_id"] == "cam_optical_frame"
    # In instance-id order (crate, ball, post), each with its class id (ball 1, crate 2,
    # post 3) as noetic's int64 hypothesis id; noetic has no instance id, source_img is empty.
    crate, ball, post = array["detections"]
    assert [d["class_id"] for d in (crate, ball, post)] == [2, 1, 3]
    assert all(d["score"] == 1.0 for d in (crate, ball, post))
    assert all(d["source_img"] == [0, 0] and d["center"][2] == 0.0 for d in (crate, ball, post))
    (cx, cy, _), (sx, sy) = crate["center"], crate["size"]
    edges = (cx - (sx - 1) / 2, cy - (sy - 1) / 2, cx + (sx - 1) / 2, cy + (sy - 1) / 2)
    for got, want in zip(edges, expected, strict=True):
        assert abs(got - want) <= 1.0, (edges, expected)
    assert (image["encoding"], image["width"], image["height"]) == ("16UC1", WIDTH, HEIGHT)
    pixels = np.frombuffer(bytes.fromhex(image["data"]), dtype="<u2").reshape(HEIGHT, WIDTH)
    assert set(np.unique(pixels)) == {0, 1, 2, 3}
    rows, cols = np.nonzero(pixels == 1)
    assert (cols.min(), rows.min(), cols.max(), rows.max()) == tuple(round(e) for e in edges)
