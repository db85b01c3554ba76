"""The ROS 2 backend (an rclpy node relaying raw CDR) and the ROS 2 tools that need no
rclpy: the venv and DDS settings of a ROS 2 process (`ros2_env`, `ros2_python`) and the
build of interface packages without a wheel (`build_packages`).

Names load on first use (PEP 562): `build_packages` or `ros2_python` import no rclpy;
`Ros2Backend` does (and works only in the ROS 2 venv).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from simbridge.lazy import lazy_face

if TYPE_CHECKING:
    from simbridge.endpoint.backends.ros2.backend import Ros2Backend, Ros2Options, ros2_cli_args
    from simbridge.endpoint.backends.ros2.build import SHIPPED_ROS2_PACKAGES, build_packages
    from simbridge.endpoint.backends.ros2.env import (
        apply_ros2_env,
        clean_stale_shm,
        fastdds_peers_profile_xml,
        ros2_env,
        ros2_python,
    )

__all__ = [
    "SHIPPED_ROS2_PACKAGES",
    "Ros2Backend",
    "Ros2Options",
    "apply_ros2_env",
    "build_packages",
    "clean_stale_shm",
    "fastdds_peers_profile_xml",
    "ros2_cli_args",
    "ros2_env",
    "ros2_python",
]

__getattr__, __dir__ = lazy_face(
    __name__,
    {
        "SHIPPED_ROS2_PACKAGES": "build",
        "Ros2Backend": "backend",
        "Ros2Options": "backend",
        "apply_ros2_env": "env",
        "build_packages": "build",
        "clean_stale_shm": "env",
        "fastdds_peers_profile_xml": "env",
        "ros2_cli_args": "backend",
        "ros2_env": "env",
        "ros2_python": "env",
    },
)
