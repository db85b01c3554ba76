"""simbridge: put a robot in MuJoCo and drive it from ROS over ROS-TCP."""

from __future__ import annotations

from simbridge.errors import SimbridgeError

__all__ = ["SimbridgeError", "__version__"]

__version__ = "0.1.0"
