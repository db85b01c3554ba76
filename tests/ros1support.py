"""Test support for real ROS 1: private roscores on free ports and the ROS command-line tools.

Every master runs in its own process group with a private ROS_HOME and log
directory, and is killed as a group when stopped. rospy allows one node per
process, so tests that run a Ros1Backend in the pytest process share
`shared_master()`; tests that run the endpoint as a subprocess start their own.
"""

from __future__ import annotations

import atexit
import importlib.util
import os
import shutil

import pytest

from simbridge.endpoint.backends.ros1_master import RosCore, free_port, terminate

__all__ = [
    "SYSTEM_PYTHON",
    "RosMaster",
    "free_port",
    "require_ros",
    "shared_master",
    "terminate",
]

SYSTEM_PYTHON = "/usr/bin/python3"
"""The interpreter Debian's rospy belongs to, for helper nodes run as subprocesses."""


def require_ros(module_level: bool = False) -> None:
    """Skip when ROS 1 is not installed, except on CI (env CI set), where that is a failure.

    With `module_level`, call it before a test module imports rospy or rosgraph.
    """
    have_python = all(importlib.util.find_spec(m) for m in ("rospy", "rosgraph"))
    if have_python and shutil.which("roscore") and shutil.which("rostopic"):
        return
    if os.environ.get("CI"):
        pytest.fail("ROS 1 (roscore, rostopic, rospy) is not installed on CI: run `make sysdeps`")
    pytest.skip("ROS 1 (roscore, rospy) is not installed", allow_module_level=module_level)


RosMaster = RosCore
"""A private roscore for tests (the product's RosCore)."""


_shared: RosMaster | None = None


def shared_master() -> RosMaster:
    """The master of this test process's rospy node, started once, stopped at exit.

    It also points this process's environment at the master, since rospy reads
    ROS_MASTER_URI and friends from os.environ when the node is created.
    """
    global _shared
    if _shared is None:
        master = RosMaster().start()
        atexit.register(master.stop)
        os.environ.update({k: v for k, v in master.env.items() if k.startswith("ROS_")})
        os.environ.pop("ROS_IP", None)
        _shared = master
    return _shared
