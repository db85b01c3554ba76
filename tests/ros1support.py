"""Test support for real ROS 1: private roscores on free ports and the ROS command-line tools.

Every master runs in its own process group with a private ROS_HOME and log
directory, and is killed as a group when stopped. rospy allows one node per
process, so tests that run a Ros1Backend in the pytest process share
`shared_master()`; tests that run the endpoint as a subprocess start their own.
"""

from __future__ import annotations

import atexit
import contextlib
import importlib.util
import os
import shutil
import signal
import socket
import subprocess
import tempfile
import time
import xmlrpc.client
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import pytest

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


def free_port() -> int:
    """A TCP port that was free a moment ago."""
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port: int = sock.getsockname()[1]
        return port


def _stat(pid: int) -> tuple[int, str] | None:
    """(parent pid, start time) of a live process, from /proc."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        return int(fields[1]), fields[19]
    except (OSError, ValueError, IndexError):
        return None


def _descendants(pid: int) -> list[tuple[int, str]]:
    """Every live process below `pid` with its start time (roslaunch gives children their
    own process groups, so killing roscore's group alone can leave them behind)."""
    children: dict[int, list[tuple[int, str]]] = {}
    for entry in Path("/proc").iterdir():
        stat = _stat(int(entry.name)) if entry.name.isdigit() else None
        if stat is not None:
            children.setdefault(stat[0], []).append((int(entry.name), stat[1]))
    found: list[tuple[int, str]] = []
    todo = [pid]
    while todo:
        for child in children.get(todo.pop(), []):
            found.append(child)
            todo.append(child[0])
    return found


def terminate(process: subprocess.Popen[bytes] | subprocess.Popen[str], grace: float = 5) -> None:
    """Stop a process started in its own session, and everything it started."""
    below = _descendants(process.pid) if process.poll() is None else []
    if process.poll() is None:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(process.pid, signal.SIGINT)
        with contextlib.suppress(subprocess.TimeoutExpired):
            process.wait(grace)
    with contextlib.suppress(ProcessLookupError):
        os.killpg(process.pid, signal.SIGKILL)
    process.wait()
    for pid, started in below:  # those that outlived a clean shutdown (same start time)
        stat = _stat(pid)
        if stat is not None and stat[1] == started:
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signal.SIGKILL)


class RosMaster:
    """A roscore on a free port with a private ROS_HOME; use as a context manager."""

    def __init__(self) -> None:
        self.port = free_port()
        self.uri = f"http://127.0.0.1:{self.port}/"
        self._home = Path(tempfile.mkdtemp(prefix="simbridge-roshome-"))
        self._process: subprocess.Popen[bytes] | None = None

    @property
    def env(self) -> dict[str, str]:
        """The environment a ROS process needs to use this master."""
        env = dict(os.environ)
        env.update(
            ROS_MASTER_URI=self.uri,
            ROS_HOSTNAME="127.0.0.1",
            ROS_HOME=str(self._home),
            ROS_LOG_DIR=str(self._home / "log"),
            PYTHONUNBUFFERED="1",
        )
        env.pop("ROS_IP", None)
        return env

    def start(self, timeout: float = 30) -> RosMaster:
        """Start roscore and wait until the master and /rosout answer."""
        log = (self._home / "roscore.out").open("wb")
        self._process = subprocess.Popen(
            ["roscore", "-p", str(self.port)],
            env=self.env,
            stdout=log,
            stderr=subprocess.STDOUT,
            stdin=subprocess.DEVNULL,
            start_new_session=True,
        )
        log.close()
        deadline = time.monotonic() + timeout
        master = xmlrpc.client.ServerProxy(self.uri)
        while time.monotonic() < deadline:
            if self._process.poll() is not None:
                break
            with contextlib.suppress(OSError):
                reply: Any = master.getSystemState("/simbridge_tests")
                code, _, state = reply
                publishers = state[0] if code == 1 else []
                if any(topic == "/rosout_agg" for topic, _ in publishers):
                    return self
            time.sleep(0.1)
        output = (self._home / "roscore.out").read_text(errors="replace")
        self.stop()
        raise RuntimeError(f"roscore on port {self.port} did not come up:\n{output}")

    def stop(self) -> None:
        """Kill roscore's whole process group and remove ROS_HOME."""
        if self._process is not None:
            terminate(self._process)
            self._process = None
        shutil.rmtree(self._home, ignore_errors=True)

    def __enter__(self) -> RosMaster:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def run(self, args: Sequence[str], timeout: float = 30) -> subprocess.CompletedProcess[str]:
        """Run a ROS tool (rostopic, rosservice ...) against this master, to completion."""
        return subprocess.run(
            list(args),
            env=self.env,
            capture_output=True,
            text=True,
            timeout=timeout,
            stdin=subprocess.DEVNULL,
            check=False,
        )

    def spawn(self, args: Sequence[str]) -> subprocess.Popen[str]:
        """Start a ROS process against this master in its own session (stop with terminate)."""
        return subprocess.Popen(
            list(args),
            env=self.env,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            stdin=subprocess.DEVNULL,
            text=True,
            start_new_session=True,
        )

    @contextlib.contextmanager
    def running(self, args: Sequence[str]) -> Iterator[subprocess.Popen[str]]:
        """`spawn` that always terminates the process on exit."""
        process = self.spawn(args)
        try:
            yield process
        finally:
            terminate(process)


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
