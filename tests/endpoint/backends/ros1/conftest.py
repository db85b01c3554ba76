"""Fixtures of the ROS 1 backend tests, which run the backend in the pytest process."""

from __future__ import annotations

import pytest
from tests.ros1support import RosMaster, require_ros, shared_master


@pytest.fixture(scope="module")
def master() -> RosMaster:
    """This process's master (rospy allows one node per process)."""
    require_ros()
    return shared_master()
