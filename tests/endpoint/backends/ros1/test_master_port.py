"""RosCore's port: without one asked for, the master binds a port the OS chooses and the
port is read back (nothing picks a port first that another process could take); a port
that was asked for is kept, and a taken one fails clearly."""

from __future__ import annotations

import xmlrpc.client
from typing import Any

import pytest
from tests.ros1support import RosMaster, require_ros

from simbridge.endpoint.backends.ros1.master import _descendants
from simbridge.errors import EndpointError

pytestmark = [pytest.mark.ros1, pytest.mark.timeout(120)]


def _master_pid(uri: str) -> int:
    reply: Any = xmlrpc.client.ServerProxy(uri).getPid("/test")
    return int(reply[2])


def _tree(pid: int) -> set[int]:
    """`pid` and every process below it."""
    return {pid, *(child for child, _ in _descendants(pid))}


def _param(uri: str, name: str) -> Any:
    reply: Any = xmlrpc.client.ServerProxy(uri).getParam("/test", name)
    code, _, value = reply
    assert code == 1, f"{name} is not set"
    return value


def test_two_masters_get_ports_from_the_os_and_answer_from_their_own_trees() -> None:
    require_ros()
    with RosMaster() as first, RosMaster() as second:
        assert first.port != 0
        assert second.port != 0
        assert first.port != second.port
        assert first.uri == f"http://127.0.0.1:{first.port}/"
        for core in (first, second):
            assert core._process is not None
            assert _master_pid(core.uri) in _tree(core._process.pid)
        # what roscore.xml sets, and a run id (rospy's log folders use it)
        assert _param(first.uri, "/rosdistro")
        assert _param(first.uri, "/rosversion")
        assert _param(first.uri, "/run_id") != _param(second.uri, "/run_id")
        done = first.run(["rostopic", "list"])
        assert "/rosout" in done.stdout.split(), done.stdout + done.stderr


def test_a_killed_master_comes_back_on_the_same_port() -> None:
    require_ros()
    with RosMaster() as core:
        port = core.port
        core.kill()
        core.start()
        assert core.port == port
        assert core._process is not None
        assert _master_pid(core.uri) in _tree(core._process.pid)


def test_a_port_asked_for_is_kept_and_a_taken_one_fails_clearly() -> None:
    require_ros()
    with RosMaster() as first:
        second = RosMaster(port=first.port)
        with pytest.raises(EndpointError, match=f"roscore on port {first.port} did not come up"):
            second.start(timeout=20)
        assert second.port == first.port


def test_the_launcher_folder_shadows_nothing_the_launcher_imports() -> None:
    """core_launch.py runs as a script, so its folder comes first on its module path: a
    module there named like a top-level one (the standard library's `types`, ROS's
    `genpy`) would be imported in its place by the launcher or by rosmaster."""
    import importlib.util
    import sys
    from pathlib import Path

    from simbridge.endpoint.backends.ros1 import core_launch

    folder = Path(core_launch.__file__).parent
    names = {path.stem for path in folder.glob("*.py")} - {"__init__"}
    shadowing = {n for n in names if n in sys.stdlib_module_names or importlib.util.find_spec(n)}
    assert not shadowing
