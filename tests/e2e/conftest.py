"""Fixtures of the ROS 1 end-to-end tests: a private roscore per module."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
from tests.ros1support import RosMaster, require_ros


@pytest.fixture(scope="module")
def master() -> Iterator[RosMaster]:
    """A roscore of the module's own, on a free port, stopped after its last test."""
    require_ros()
    with RosMaster() as master:
        yield master
