"""A short live demo of the bridge: an endpoint, two connectors, a topic and a service."""

from __future__ import annotations

import json as json_text
import threading
import time
from contextlib import ExitStack
from typing import Any

from simbridge.apps.ros_master import DemoMaster
from simbridge.connector import Connector, ConnectorOptions
from simbridge.endpoint import Backend, EndpointOptions, EndpointThread, LocalBus, make_backend
from simbridge.endpoint.backends.ros1 import unique_node_name
from simbridge.errors import AppError

__all__ = ["run_bridge_demo"]


def run_bridge_demo(
    count: int = 5, rate_hz: float = 10.0, backend: str = "local", json: bool = False
) -> int:
    """Twist messages from a 'sim' connector to a 'ROS tool' connector, then a service call back.

    `backend` "ros1" routes them through a ROS 1 master (ROS_MASTER_URI, else a private
    roscore) as real topics and services; "ros2" through rclpy (the ROS 2 venv, localhost
    DDS), the connectors speaking ROS 2 (CDR). Returns the number of Twist messages that
    arrived (the demo fails if any was lost). `json` prints a summary as the last line
    (SUMMARY_KEYS, then sent, received, service_ok).
    """
    began = time.perf_counter()
    options = ConnectorOptions(reconnect_initial=0.2)
    with ExitStack() as stack:
        graph: Backend = LocalBus()
        if backend == "ros1":
            master = stack.enter_context(DemoMaster())
            print(f"[endpoint] ROS master {master.describe()}")
            graph = make_backend("ros1", node_name=unique_node_name("simbridge_bridge_demo"))
        elif backend == "ros2":
            graph = make_backend("ros2", node_name="/simbridge_bridge_demo")
        elif backend != "local":
            raise AppError(f"unknown backend {backend!r}; choose local, ros1 or ros2")
        endpoint = stack.enter_context(EndpointThread(EndpointOptions(port=0), graph))
        print(f"[endpoint] listening on 127.0.0.1:{endpoint.port} (backend {backend})")
        with (
            Connector("127.0.0.1", endpoint.port, options).connect() as sim,
            Connector("127.0.0.1", endpoint.port, options).connect() as tool,
        ):
            reg = sim.registry  # the endpoint's layouts (ROS 2 ones on a ros2 endpoint)
            got = threading.Event()
            received: list[Any] = []

            def on_twist(msg: Any) -> None:
                received.append(msg)
                print(
                    f"[tool] /cmd_vel <- linear.x={msg.linear.x:.2f} angular.z={msg.angular.z:.2f}"
                )
                if len(received) == count:
                    got.set()

            def reset(req: Any) -> Any:
                print("[sim] /reset_odometry called: resetting")
                return reg.new("std_srvs/TriggerResponse", success=True, message="odometry reset")

            tool.subscribe("/cmd_vel", "geometry_msgs/Twist", on_twist)
            sim.implement_service("/reset_odometry", "std_srvs/Trigger", reset)
            tool.register_ros_service("/reset_odometry", "std_srvs/Trigger")
            pub = sim.register_publisher("/cmd_vel", "geometry_msgs/Twist", report_subscribers=True)
            # Like ROS, a message published before the subscriber is connected is not seen
            # by it: wait until the endpoint reports the tool's subscription.
            deadline = time.monotonic() + 5.0
            while not pub.subscriber_count and time.monotonic() < deadline:
                time.sleep(0.05)
            for i in range(count):
                msg = reg.new("geometry_msgs/Twist")
                msg.linear.x = 0.1 * (i + 1)
                msg.angular.z = -0.05 * i
                print(
                    f"[sim] /cmd_vel -> linear.x={msg.linear.x:.2f} angular.z={msg.angular.z:.2f}"
                )
                pub.publish(msg)
                time.sleep(1.0 / rate_hz)
            got.wait(5.0)
            response = tool.call("/reset_odometry", reg.new("std_srvs/TriggerRequest"), timeout=5)
            print(
                f"[tool] /reset_odometry -> success={response.success} message={response.message!r}"
            )
            print(f"[tool] topics: {tool.topic_list()}")
            server = tool.endpoint_stats()["server"]
            print(
                f"[endpoint] clients={server['clients']} frames_in={server['frames_in']} "
                f"dropped={server['dropped_total']}"
            )
    print(f"demo: {len(received)}/{count} messages delivered, service call ok={response.success}")
    if json:
        success = len(received) == count and bool(response.success)
        wall = time.perf_counter() - began
        summary = {
            "success": success,
            "seed": None,
            "backend": backend,
            "sim_s": None,  # no simulation: two connectors and an endpoint
            "wall_s": round(wall, 4),
            "realtime_factor": None,
            "error": None
            if success
            else f"{len(received)} of {count} messages arrived, service call ok "
            f"{bool(response.success)}",
            "sent": count,
            "received": len(received),
            "service_ok": bool(response.success),
        }
        print(json_text.dumps(summary), flush=True)
    return len(received)
