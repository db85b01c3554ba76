"""The sim as its own ROS 2 node: `simbridge sim SCENE --ros2`.

An rclpy node (the ros2 backend, `/simbridge_sim` by default) run by an endpoint in this
process that listens on no port: the sim's connectors reach it through socketpairs
(`NodeConnector`) and publish their topics straight into rclpy. The scene's ROS layer
runs unchanged, so the topics, services, actions, TF, /clock and robot_description are
those a sim serves through `simbridge endpoint --backend ros2`, without the TCP hop or the
endpoint process. Needs rclpy in the running interpreter (the ROS 2 venv, `make ros2`).
"""

from __future__ import annotations

import importlib.util
import sys
from typing import TYPE_CHECKING

from simbridge.apps.ros2_node.publisher import NodeConnector
from simbridge.connector import Connector, ConnectorOptions
from simbridge.errors import AppError

if TYPE_CHECKING:
    from simbridge.endpoint.runner import EndpointThread

__all__ = ["DEFAULT_NODE_NAME", "Ros2SimNode", "require_rclpy"]

DEFAULT_NODE_NAME = "simbridge_sim"


def require_rclpy() -> None:
    """AppError, saying which Python has it, unless rclpy imports in this interpreter."""
    if importlib.util.find_spec("rclpy") is not None:
        return
    from simbridge.endpoint.backends.ros2 import ros2_python  # noqa: PLC0415 - no rclpy

    venv = ros2_python()
    where = (
        f"run it with the ROS 2 venv's Python: {venv.parent / 'simbridge'} sim ... --ros2 "
        f"(or {venv} -m simbridge.cli sim ... --ros2)"
        if venv is not None
        else "build the ROS 2 venv first (`make ros2`), then run .venv-ros2/bin/simbridge "
        "sim ... --ros2"
    )
    raise AppError(
        f"--ros2 runs the sim as an rclpy node, but rclpy is not importable in {sys.executable}; "
        f"{where}"
    )


class Ros2SimNode:
    """The sim's rclpy node and the endpoint in this process that runs it; `connector()`
    makes the sim's connections to it. Use as a context manager, or `start()` then `close()`."""

    def __init__(
        self,
        node_name: str = DEFAULT_NODE_NAME,
        ros_args: tuple[str, ...] = (),
        domain_id: int | None = None,
        drain_timeout: float = 5.0,
    ) -> None:
        """`ros_args`: rcl arguments (`-r __ns:=/robot`, remappings); `domain_id` replaces
        ROS_DOMAIN_ID; `drain_timeout`: how long closing waits for subscribers to
        acknowledge what was published."""
        self.node_name = node_name
        self._ros_args = ros_args
        self._domain_id = domain_id
        self._drain_timeout = drain_timeout
        self._thread: EndpointThread | None = None
        self._connectors: list[Connector] = []

    @property
    def endpoint(self) -> EndpointThread:
        """The endpoint thread (AppError before `start()`)."""
        if self._thread is None:
            raise AppError(f"the ROS 2 node {self.node_name!r} is not started: call start()")
        return self._thread

    def start(self) -> Ros2SimNode:
        """Join the ROS 2 graph (AppError without rclpy, EndpointError when rcl refuses)."""
        if self._thread is not None:
            return self
        require_rclpy()
        from simbridge.endpoint import EndpointOptions, EndpointThread  # noqa: PLC0415
        from simbridge.endpoint.backends.ros2 import Ros2Backend, Ros2Options  # noqa: PLC0415

        backend = Ros2Backend(
            Ros2Options(
                node_name=self.node_name, ros_args=self._ros_args, domain_id=self._domain_id
            )
        )
        options = EndpointOptions(port=0, idle_timeout=0.0, drain_timeout=self._drain_timeout)
        self._thread = EndpointThread(options, backend, listen=False).start()
        return self

    def connector(
        self, options: ConnectorOptions | None = None, wait: float | None = 10.0
    ) -> Connector:
        """A new connection of the sim to the node, connected (within `wait` s)."""
        connector = NodeConnector(self.endpoint, f"ros2 node {self.node_name}", options)
        self._connectors.append(connector)
        return connector.connect(wait)

    def close(self) -> None:
        """Close the connectors it made (if still open), deliver what was published (up to
        `drain_timeout`) and leave the graph."""
        for connector in self._connectors:
            connector.close()
        self._connectors.clear()
        if self._thread is not None:
            self._thread.stop(timeout=self._drain_timeout + 10.0)
            self._thread = None

    def __enter__(self) -> Ros2SimNode:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()
