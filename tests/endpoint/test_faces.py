"""The endpoint's package faces load on first use: the local path (import, a local
endpoint relaying a client's messages to an in-process node) and the ROS-free ROS tools
import neither rospy nor rclpy. Each check runs in a fresh interpreter."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap

import pytest

from tests.ros2support import Ros2Process

ROS_MODULES = ("rospy", "rosgraph", "genpy", "rclpy")

_LOADED = f"""
import json, sys
print(json.dumps([m for m in {ROS_MODULES!r} if m in sys.modules]))
"""


def _ros_modules_loaded(script: str) -> list[str]:
    """The ROS modules imported by the time `script` (run in a fresh interpreter) ends."""
    done = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(script) + _LOADED],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    loaded: list[str] = json.loads(done.stdout.strip().splitlines()[-1])
    return loaded


def test_a_local_endpoint_imports_no_ros() -> None:
    script = """
    import queue
    import simbridge.endpoint as endpoint
    from simbridge.connector import Connector

    backend = endpoint.make_backend("local")
    with endpoint.EndpointThread(endpoint.EndpointOptions(port=0), backend) as ep:
        got = queue.Queue()
        with endpoint.Node(backend, "/listener") as node:
            node.subscribe("/cmd_vel", "geometry_msgs/Twist", got.put)
            with Connector("127.0.0.1", ep.port).connect() as ros:
                pub = ros.register_publisher("/cmd_vel", "geometry_msgs/Twist")
                twist = ros.registry.new("geometry_msgs/Twist", linear={"x": 0.5})
                for _ in range(200):  # until the registration has reached the bus
                    pub.publish(twist)
                    try:
                        received = got.get(timeout=0.05)
                        break
                    except queue.Empty:
                        continue
                else:
                    raise SystemExit("no message arrived")
    assert received.linear.x == 0.5
    """
    assert _ros_modules_loaded(script) == []


def test_the_ros_free_tools_import_no_ros() -> None:
    script = """
    from simbridge.endpoint.backends.ros1 import RosCore, generate_python_messages
    from simbridge.endpoint.backends.ros1 import master_answers, unique_node_name
    assert RosCore and generate_python_messages and master_answers and unique_node_name
    """
    assert _ros_modules_loaded(script) == []


@pytest.mark.ros2
def test_the_ros2_face_resolves_in_the_ros2_venv_and_its_tools_need_no_rclpy() -> None:
    """Every name of backends.ros2 loads where rclpy is installed (the main venv cannot
    load Ros2Backend), and `build_packages` and `ros2_python` load without rclpy."""
    script = textwrap.dedent(
        """
        import json, sys
        from simbridge.endpoint.backends.ros2 import build_packages, ros2_python
        tools = "rclpy" in sys.modules
        import simbridge.endpoint.backends.ros2 as face
        missing = [name for name in face.__all__ if not hasattr(face, name)]
        print(json.dumps({"face": {"tools_load_rclpy": tools, "missing": missing,
                                   "rclpy": "rclpy" in sys.modules}}), flush=True)
        """
    )
    with Ros2Process(["-c", script]) as proc:
        result = proc.expect_json("face", timeout=60)
    assert result == {"tools_load_rclpy": False, "missing": [], "rclpy": True}
