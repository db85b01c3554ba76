"""The sim as its own ROS 2 node (`simbridge sim SCENE --ros2`): an rclpy node in the sim's
process instead of a connector to an endpoint process; needs the ROS 2 venv's Python."""

from __future__ import annotations

from simbridge.apps.ros2_node.node import DEFAULT_NODE_NAME, Ros2SimNode, require_rclpy
from simbridge.apps.ros2_node.publisher import DirectPublisher, NodeConnector

__all__ = ["DEFAULT_NODE_NAME", "DirectPublisher", "NodeConnector", "Ros2SimNode", "require_rclpy"]
