"""Suite-wide settings: nothing is judged by the machine's speed, and ROS 2 graphs take turns.

Hypothesis's per-example deadline and too-slow health check time examples on the wall
clock, so on a loaded machine (or beside another pytest worker) they fail correct tests.

Under pytest-xdist with `--dist loadfile` (`make test`, two workers) each test file runs
whole on one worker, so a module's fixtures start once, except that every file that runs
ROS 2 processes goes to one worker as one unit, "dds": two Fast DDS graphs in different
domains at once meet shared-memory port clashes ("open_and_lock_file failed" on
fastrtps_port7000/7001, ports every domain shares; Fast DDS gives up waiting for a port's
lock after 2 s, eProsima/Fast-DDS#6117), and a long-lived endpoint then stops hearing nodes
started later. tests/scheduling.py's scheduler makes that unit, not `xdist_group` markers:
under pytest 9, pytest-xdist 3.8 cannot rename a test's node id to carry its group, so
`--dist loadgroup` silently ran files of "dds" on both workers at once.
"""

from __future__ import annotations

from typing import Any

from hypothesis import HealthCheck, settings

from tests.scheduling import FilesAndDds

settings.register_profile("simbridge", deadline=None, suppress_health_check=[HealthCheck.too_slow])
settings.load_profile("simbridge")


def pytest_xdist_make_scheduler(config: Any, log: Any) -> FilesAndDds | None:
    """Our scheduler for `--dist loadfile`; other modes keep pytest-xdist's own."""
    return FilesAndDds(config, log) if config.getvalue("dist") == "loadfile" else None
