"""The backend an endpoint runs with, by name: the embedded local bus, ROS 1 or ROS 2 (their
modules, and rospy or rclpy, are imported only when asked for)."""

from __future__ import annotations

from simbridge.endpoint.backends.base import Backend
from simbridge.endpoint.backends.local import LocalBus
from simbridge.errors import EndpointError

__all__ = ["BACKENDS", "make_backend"]

BACKENDS = ("local", "ros1", "ros2")


def make_backend(
    name: str,
    *,
    node_name: str = "/simbridge_endpoint",
    ros_args: tuple[str, ...] = (),
    protocol: str | None = None,
    ros1_transport: str = "native",
) -> Backend:
    """The backend called `name` ("local", "ros1" or "ros2").

    `ros_args` are ROS arguments: `a:=b` for ros1; for ros2, rcl's `--ros-args` items
    (ROS 1 style `a:=b` ones are translated). `protocol` ("ROS1" or "ROS2") picks the
    local bus's serialization; other backends have their own and refuse a different one.
    `ros1_transport` ("native" or "rospy") picks the ros1 backend's topic data path.
    """
    if name == "local":
        if protocol == "ROS2":
            return LocalBus("ROS2")
        if protocol not in (None, "ROS1"):
            raise EndpointError(f"protocol {protocol!r} is not one of ROS1, ROS2")
        return LocalBus()
    if protocol not in (None, "ROS2") and name == "ros2":
        raise EndpointError(f"the ros2 backend speaks ROS2, not {protocol}")
    if protocol not in (None, "ROS1") and name == "ros1":
        raise EndpointError(f"the ros1 backend speaks ROS1, not {protocol}")
    if name == "ros1":
        from simbridge.endpoint.backends.ros1.backend import (  # noqa: PLC0415 - rospy is optional
            Ros1Backend,
            Ros1Options,
        )

        if ros1_transport not in ("native", "rospy"):
            raise EndpointError(f"ros1 transport {ros1_transport!r} is not one of native, rospy")
        return Ros1Backend(
            Ros1Options(
                node_name=node_name.lstrip("/"),
                ros_args=ros_args,
                transport="native" if ros1_transport == "native" else "rospy",
            )
        )
    if name == "ros2":
        from simbridge.endpoint.backends.ros2.backend import (  # noqa: PLC0415 - rclpy is optional
            Ros2Backend,
            Ros2Options,
            ros2_cli_args,
        )

        return Ros2Backend(Ros2Options(node_name=node_name, ros_args=ros2_cli_args(ros_args)))
    raise EndpointError(f"unknown backend {name!r}; choose one of {', '.join(BACKENDS)}")
