"""Suite-wide settings: nothing is judged by the machine's speed, and ROS 2 graphs take turns.

Hypothesis's per-example deadline and too-slow health check time examples on the wall
clock, so on a loaded machine (or beside another pytest worker) they fail correct tests.

Under pytest-xdist (`make test`: `--dist loadgroup`) each test file is a group of its own,
so a module's fixtures start once, except that every file that runs ROS 2 processes joins
one group, "dds": two Fast DDS graphs in different domains at once met shared-memory port
clashes ("open_and_lock_file failed" on fastrtps_port7000/7001, ports every domain shares;
Fast DDS gives up waiting for a port's lock after 2 s, eProsima/Fast-DDS#6117) and a matched
subscriber that never got a sample.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import HealthCheck, settings

settings.register_profile("simbridge", deadline=None, suppress_health_check=[HealthCheck.too_slow])
settings.load_profile("simbridge")

_DDS_SIGNS = ("tests.ros2support", "pytest.mark.ros2", "benchmarks.bench_ros2")


def _runs_dds(path: Path, seen: dict[Path, bool]) -> bool:
    if path not in seen:
        text = path.read_text(encoding="utf-8", errors="replace")
        seen[path] = any(sign in text for sign in _DDS_SIGNS)
    return seen[path]


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """An xdist group per test file, and one for all files that run ROS 2 processes."""
    seen: dict[Path, bool] = {}
    for item in items:
        path = Path(item.path)
        group = "dds" if _runs_dds(path, seen) else item.nodeid.split("::", 1)[0]
        item.add_marker(pytest.mark.xdist_group(group))
