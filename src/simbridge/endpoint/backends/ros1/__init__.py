"""The ROS 1 backend (a rospy node whose topics move over the endpoint's own TCPROS
connections) and the ROS 1 tools that need no rospy: the master (`RosCore`), message
Python modules for the ROS tools (`generate_python_messages`), a service probe.

Names load on first use (PEP 562): `RosCore` or `generate_python_messages` import no rospy;
`Ros1Backend` does.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from simbridge.lazy import lazy_face

if TYPE_CHECKING:
    from simbridge.endpoint.backends.ros1.backend import Ros1Backend, Ros1Options, Ros1Publisher
    from simbridge.endpoint.backends.ros1.drained_process import DrainedProcess
    from simbridge.endpoint.backends.ros1.master import (
        RosCore,
        master_answers,
        terminate,
        unique_node_name,
    )
    from simbridge.endpoint.backends.ros1.msg_genpy import generate_python_messages
    from simbridge.endpoint.backends.ros1.msg_types import Ros1Types
    from simbridge.endpoint.backends.ros1.node import (
        join_graph,
        leave_graph,
        on_node_shutdown,
        read_drop_in_params,
        ros_args,
    )
    from simbridge.endpoint.backends.ros1.probe import probe_service
    from simbridge.endpoint.backends.ros1.raw import (
        RawMessage,
        raw_message_class,
        raw_service_class,
    )

__all__ = [
    "DrainedProcess",
    "RawMessage",
    "Ros1Backend",
    "Ros1Options",
    "Ros1Publisher",
    "Ros1Types",
    "RosCore",
    "generate_python_messages",
    "join_graph",
    "leave_graph",
    "master_answers",
    "on_node_shutdown",
    "probe_service",
    "raw_message_class",
    "raw_service_class",
    "read_drop_in_params",
    "ros_args",
    "terminate",
    "unique_node_name",
]

__getattr__, __dir__ = lazy_face(
    __name__,
    {
        "DrainedProcess": "drained_process",
        "RawMessage": "raw",
        "Ros1Backend": "backend",
        "Ros1Options": "backend",
        "Ros1Publisher": "backend",
        "Ros1Types": "msg_types",
        "RosCore": "master",
        "generate_python_messages": "msg_genpy",
        "join_graph": "node",
        "leave_graph": "node",
        "master_answers": "master",
        "on_node_shutdown": "node",
        "probe_service": "probe",
        "raw_message_class": "raw",
        "raw_service_class": "raw",
        "read_drop_in_params": "node",
        "ros_args": "node",
        "terminate": "master",
        "unique_node_name": "master",
    },
)
