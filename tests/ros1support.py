"""Test support for real ROS 1: private roscores on free ports, the ROS command-line tools
and `simbridge endpoint --backend ros1` subprocesses.

Every master runs in its own process group with a private ROS_HOME and log
directory, and is killed as a group when stopped. rospy allows one node per
process, so tests that run a Ros1Backend in the pytest process share
`shared_master()`; tests that run the endpoint as a subprocess (`EndpointProcess`)
start their own.
"""

from __future__ import annotations

import asyncio
import atexit
import importlib.util
import os
import re
import shutil
import signal
import struct
import subprocess
import sys
import threading
import time
from collections.abc import Awaitable, Callable
from typing import TYPE_CHECKING, TypeVar

import pytest

from simbridge.connector import ConnectorOptions
from simbridge.endpoint.backends.ros1 import DrainedProcess, RosCore, terminate

if TYPE_CHECKING:  # rospy is imported only once require_ros() let the tests run
    from simbridge.endpoint.backends.ros1 import Ros1Backend, Ros1Options

T = TypeVar("T")

__all__ = [
    "FAST",
    "SYSTEM_PYTHON",
    "DrainedProcess",
    "EndpointProcess",
    "RosMaster",
    "require_ros",
    "ros_string",
    "shared_master",
    "terminate",
    "until",
    "wait_until",
    "with_backend",
]

SYSTEM_PYTHON = "/usr/bin/python3"
"""The interpreter Debian's rospy belongs to, for helper nodes run as subprocesses."""

FAST = ConnectorOptions(
    keepalive_interval=0.2,
    dead_timeout=10.0,  # a loaded machine can leave the endpoint silent a while: no drops
    connect_timeout=1.0,
    reconnect_initial=0.1,
    reconnect_max=0.5,
    service_timeout=10.0,
    request_timeout=5.0,
)
"""Connector timings for tests against a local endpoint: crashes and restarts show fast."""


def ros_string(text: str) -> bytes:
    """std_msgs/String by hand: uint32 LE length + UTF-8 bytes."""
    raw = text.encode()
    return struct.pack("<I", len(raw)) + raw


async def until(predicate: Callable[[], bool], timeout: float, what: str) -> None:
    """`wait_until` on an event loop: the loop runs while it polls."""
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what}")
        await asyncio.sleep(0.02)


def with_backend(
    scenario: Callable[[Ros1Backend], Awaitable[T]], options: Ros1Options | None = None
) -> T:
    """Run `scenario` on a fresh event loop with a started Ros1Backend (this process's
    node, on `shared_master()`), closing it after."""
    from simbridge.endpoint.backends.ros1 import Ros1Backend

    async def main() -> T:
        backend = Ros1Backend(options)
        await backend.start()
        try:
            return await scenario(backend)
        finally:
            await backend.close()

    return asyncio.run(main())


def wait_until(predicate: Callable[[], bool], timeout: float, what: str) -> float:
    """Poll `predicate` until true; the seconds it took. AssertionError naming `what`
    after `timeout` seconds."""
    start = time.monotonic()
    while not predicate():
        if time.monotonic() - start > timeout:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(0.05)
    return time.monotonic() - start


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
"""A private roscore for tests: the product's RosCore, whose `spawn` (and so `running`)
starts a `DrainedProcess` (its output read all the time, so it never blocks)."""


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


_LISTENING = re.compile(r"listening on \S+:(\d+)")


class EndpointProcess:
    """`simbridge endpoint --backend ros1` on `master`'s graph, in its own session.

    The constructor returns once the endpoint listens (on `port`; by default on one the
    OS picks when it binds, read back from its "listening on" line, so no other process
    can take it between choosing and binding); an endpoint that exits or says nothing of
    the kind within `timeout` seconds is stopped and fails the test with its output. Its
    output lines are collected in `lines` by a reader thread, so the pipe never fills.
    """

    def __init__(
        self, master: RosMaster, node_name: str, *extra: str, port: int = 0, timeout: float = 60
    ) -> None:
        self.port = port
        self.node_name = node_name
        command = [sys.executable, "-m", "simbridge.cli", "endpoint", "--backend", "ros1"]
        options = ["--port", str(port), "--idle-timeout", "0", "--node-name", node_name]
        self.process = subprocess.Popen(
            [*command, *options, *extra],
            env=master.env,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            stdin=subprocess.DEVNULL,
            text=True,
            start_new_session=True,
        )
        self.lines: list[str] = []
        self._listening = False
        self._started = threading.Event()
        """Set when the endpoint says it listens, or its output ends."""
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()
        if not (self._started.wait(timeout) and self._listening):
            self.stop()
            raise AssertionError("the endpoint did not start:\n" + self.output())

    def _read(self) -> None:
        assert self.process.stdout is not None
        for line in self.process.stdout:
            self.lines.append(line)
            match = None if self._listening else _LISTENING.search(line)
            if match:
                self.port = int(match[1])
                self._listening = True
                self._started.set()
        self._started.set()

    def output(self) -> str:
        return "".join(self.lines)

    def kill(self) -> None:
        """Crash it: SIGKILL, no chance to unregister."""
        self.process.send_signal(signal.SIGKILL)
        self.process.wait(10)

    def stop(self) -> None:
        terminate(self.process)
