"""Test support for real ROS 2: the ROS 2 venv's Python, a private domain, helper nodes.

pytest runs in the main venv (beside Debian's rospy), so everything rclpy runs in
subprocesses with the ROS 2 venv's Python: the endpoint itself and the helper nodes
in tests/ros2/ros2_node.py. Each pytest process takes a ROS domain of its own (a
lock file per domain id) and every child gets the localhost-only settings of
simbridge.endpoint.backends.ros2.env. Children are stopped with SIGINT (so Fast DDS
removes its shared memory) and killed if that fails; stale /dev/shm files are
removed at exit.
"""

from __future__ import annotations

import atexit
import fcntl
import json
import os
import queue
import re
import signal
import subprocess
import tempfile
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

import pytest

from simbridge.endpoint.backends.ros2 import clean_stale_shm, ros2_env, ros2_python

__all__ = [
    "NODE_SCRIPT",
    "ActionDriver",
    "Ros2Process",
    "child_env",
    "domain_id",
    "require_ros2",
    "start_endpoint",
    "until_discovered",
]

T = TypeVar("T")

UNDISCOVERED = ("no ROS 2 server", "did not answer")
"""What a ROS 2 endpoint's `__error` says of a call whose server it has not discovered, or
whose server answered before it had matched the endpoint's new client (the answer is lost)."""

NODE_SCRIPT = Path(__file__).parent / "ros2" / "ros2_node.py"
DRIVER_SCRIPT = Path(__file__).parent / "ros2" / "action_driver.py"

_DOMAIN: int | None = None
_DOMAIN_LOCK: int | None = None


def require_ros2() -> Path:
    """The ROS 2 venv's Python; skip without it, except on CI (env CI), where that fails."""
    python = ros2_python()
    if python is not None:
        return python
    if os.environ.get("CI"):
        pytest.fail("the ROS 2 venv (.venv-ros2) is missing on CI: run `make ros2`")
    pytest.skip("the ROS 2 venv (.venv-ros2) is not installed: run `make ros2`")


def domain_id() -> int:
    """A ROS domain id no other test process on this machine holds (1..100)."""
    global _DOMAIN, _DOMAIN_LOCK
    if _DOMAIN is not None:
        return _DOMAIN
    start = os.getpid() % 100
    for i in range(100):
        candidate = 1 + (start + i) % 100
        path = Path(tempfile.gettempdir()) / f"simbridge-ros-domain-{candidate}.lock"
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            os.close(fd)
            continue
        _DOMAIN, _DOMAIN_LOCK = candidate, fd
        atexit.register(clean_stale_shm)
        return candidate
    raise RuntimeError("no free ROS domain id in 1..100")


def child_env() -> dict[str, str]:
    """The environment of a ROS 2 child: localhost only, this process's domain, no ROS 1."""
    base = {
        k: v
        for k, v in os.environ.items()
        if k not in ("PYTHONPATH", "ROS_MASTER_URI", "ROS_PACKAGE_PATH", "ROS_DISTRO")
        and not k.startswith("_ROS_WHEELS")
    }
    base["PYTHONUNBUFFERED"] = "1"
    return ros2_env(base, domain_id=domain_id())


class Ros2Process:
    """A child process run with the ROS 2 venv's Python; stdout lines are collected."""

    def __init__(
        self, args: list[str], *, env: dict[str, str] | None = None, interactive: bool = False
    ) -> None:
        python = require_ros2()
        self.args = args
        self.proc = subprocess.Popen(
            [str(python), *args],
            stdin=subprocess.PIPE if interactive else None,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            env=env or child_env(),
            text=True,
            start_new_session=True,
        )
        self.lines: queue.Queue[str] = queue.Queue()
        self.output: list[str] = []
        threading.Thread(target=self._read, daemon=True).start()

    @classmethod
    def node(cls, *args: str) -> Ros2Process:
        """A helper node (see tests/ros2/ros2_node.py for the modes)."""
        return cls([str(NODE_SCRIPT), *args])

    def send(self, obj: object) -> None:
        """One JSON line to the child's stdin (an `interactive` one)."""
        assert self.proc.stdin is not None, "not started interactive"
        self.proc.stdin.write(json.dumps(obj) + "\n")
        self.proc.stdin.flush()

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self.output.append(line)
            self.lines.put(line)

    def expect_line(self, pattern: str, timeout: float = 20.0) -> re.Match[str]:
        """The next output line matching `pattern` (a regex)."""
        deadline = time.monotonic() + timeout
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                raise AssertionError(
                    f"no line matching {pattern!r} within {timeout} s; output:\n"
                    + "".join(self.output[-30:])
                )
            try:
                line = self.lines.get(timeout=min(left, 0.2))
            except queue.Empty:
                if self.proc.poll() is not None and self.lines.empty():
                    raise AssertionError(
                        f"process exited ({self.proc.returncode}) before {pattern!r}; output:\n"
                        + "".join(self.output[-30:])
                    ) from None
                continue
            match = re.search(pattern, line)
            if match:
                return match

    def expect_json(self, key: str, timeout: float = 20.0) -> Any:
        """The value of `key` in the next JSON line that has it."""
        match = self.expect_line(r'^\{"' + re.escape(key) + '"', timeout)
        return json.loads(match.string)[key]

    def stop(self, timeout: float = 5.0) -> None:
        """SIGINT (a clean rclpy shutdown frees shared memory), then SIGKILL if needed."""
        if self.proc.poll() is None:
            try:
                os.killpg(self.proc.pid, signal.SIGINT)
                self.proc.wait(timeout)
            except subprocess.TimeoutExpired:
                os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.wait(timeout)
            except ProcessLookupError:
                pass

    def __enter__(self) -> Ros2Process:
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()
        if exc[0] is not None:  # pytest shows this with the failure
            print(f"{' '.join(self.args)} output:\n" + "".join(self.output[-40:]))


class ActionDriver:
    """tests/ros2/action_driver.py: plain rclpy ActionClients driven over stdin. Every JSON
    line it printed is kept, so replies are found by key and tag in any order."""

    def __init__(self) -> None:
        self.proc = Ros2Process([str(DRIVER_SCRIPT)], interactive=True)
        self.seen: list[dict[str, Any]] = []

    def send(self, **command: Any) -> None:
        self.proc.send(command)

    def expect(self, test: Callable[[dict[str, Any]], bool], timeout: float = 60.0) -> Any:
        """The first line (seen or coming) that passes `test`, taken out of `seen`."""
        deadline = time.monotonic() + timeout
        while True:
            for i, obj in enumerate(self.seen):
                if test(obj):
                    return self.seen.pop(i)
            left = deadline - time.monotonic()
            if left <= 0 or self.proc.proc.poll() is not None:
                raise AssertionError(
                    f"no matching line in {timeout} s; output:\n" + "".join(self.proc.output[-30:])
                )
            try:
                line = self.proc.lines.get(timeout=min(left, 0.2))
            except queue.Empty:
                continue
            if line.startswith("{"):
                self.seen.append(json.loads(line))

    def reply(self, key: str, tag: str) -> Any:
        return self.expect(lambda o: o.get(key) == tag)

    def wait_ready(self, action: str, action_type: str) -> None:
        self.send(op="wait", action=action, type=action_type)
        assert self.reply("ready", action)["ok"] is True

    def goal(self, tag: str, values: dict[str, Any], *, action: str, kind: str) -> None:
        """Send a goal (`kind` pkg/action/Type, fields as JSON) tagged `tag`."""
        self.send(op="goal", tag=tag, action=action, type=kind, goal=values)


def start_endpoint(*extra: str) -> tuple[Ros2Process, int]:
    """`simbridge endpoint --backend ros2` on a free port; returns it and the port."""
    proc = Ros2Process(
        ["-m", "simbridge.cli", "endpoint", "--backend", "ros2", "--port", "0", *extra]
    )
    match = proc.expect_line(r"listening on 127\.0\.0\.1:(\d+)", timeout=60)
    return proc, int(match.group(1))


def until_discovered(call: Callable[[], T], timeout: float = 180.0) -> T:
    """`call()` again while it fails because the endpoint and a ROS 2 server have not
    discovered each other yet: the endpoint gives up on discovery after 5 s, a server's own
    "ready" does not bound when the endpoint's node sees it on a busy machine, and a server
    that answers a client it has not matched yet loses the answer (rmw_fastrtps waits only
    briefly for that match)."""
    deadline = time.monotonic() + timeout
    while True:
        try:
            return call()
        except Exception as exc:
            if not any(sign in str(exc) for sign in UNDISCOVERED) or time.monotonic() > deadline:
                raise
