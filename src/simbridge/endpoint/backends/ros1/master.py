"""A private ROS 1 master (roscore) on a port the OS chooses, and clean process shutdown.

Used by the demos (when no master answers at ROS_MASTER_URI) and by the test suite.
Every roscore runs in its own session with a private ROS_HOME; stopping it kills its
whole process tree, since roslaunch gives its children process groups of their own.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import urllib.parse
import xmlrpc.client
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

from simbridge.endpoint.backends.ros1.drained_process import DrainedProcess
from simbridge.errors import EndpointError

__all__ = ["RosCore", "master_answers", "terminate", "unique_node_name"]

_CALLER = "/simbridge"


def unique_node_name(base: str) -> str:
    """`base` made unique the way rospy's anonymous names are (`base_<pid>_<ms>`), so a demo
    never shuts down a running node of the same name (the master keeps the newest)."""
    return f"{base.lstrip('/')}_{os.getpid()}_{int(time.time() * 1000)}"


def master_answers(uri: str, timeout: float = 1.0) -> bool:
    """True when a ROS master answers getPid at `uri`."""
    url = urllib.parse.urlparse(uri)
    if not url.hostname or not url.port:
        return False
    try:
        with socket.create_connection((url.hostname, url.port), timeout=timeout):
            pass
        reply: Any = xmlrpc.client.ServerProxy(uri).getPid(_CALLER)
    except (OSError, xmlrpc.client.Error):
        return False
    return isinstance(reply, list | tuple) and len(reply) == 3 and reply[0] == 1


def _stat(pid: int) -> tuple[int, str] | None:
    """(parent pid, start time) of a live process, from /proc."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        return int(fields[1]), fields[19]
    except (OSError, ValueError, IndexError):
        return None


def _descendants(pid: int) -> list[tuple[int, str]]:
    """Every live process below `pid`, with its start time."""
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
    """Stop a process started in its own session, and everything it started:
    SIGINT to its group, SIGKILL after `grace` seconds, then any descendant left."""
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


class RosCore:
    """A roscore with a private ROS_HOME; use as a context manager.

    Without a port, the master binds one the OS chooses (`core_launch`) and `port` and
    `uri` are read back once it serves: no port is picked first that another process could
    take. With a port (or after a first start, so `kill` and `start` keep the URI), the
    real `roscore -p PORT` runs.
    """

    def __init__(self, port: int | None = None) -> None:
        self.port = port or 0
        self.uri = f"http://127.0.0.1:{self.port}/" if port else ""
        self.home = Path(tempfile.mkdtemp(prefix="simbridge-roshome-"))
        self._process: subprocess.Popen[bytes] | None = None

    @property
    def env(self) -> dict[str, str]:
        """The environment a ROS process needs to use this master."""
        env = dict(os.environ)
        env.update(
            ROS_MASTER_URI=self.uri,
            ROS_HOSTNAME="127.0.0.1",
            ROS_HOME=str(self.home),
            ROS_LOG_DIR=str(self.home / "log"),
            PYTHONUNBUFFERED="1",
        )
        env.pop("ROS_IP", None)
        return env

    def start(self, timeout: float = 30) -> RosCore:
        """Start the master and wait until it and /rosout answer."""
        if shutil.which("roscore") is None or shutil.which("rosmaster") is None:
            raise EndpointError("roscore is not installed; install ros-core (make sysdeps)")
        deadline = time.monotonic() + timeout
        if self._launch(deadline):
            return self
        output = (self.home / "roscore.out").read_text(errors="replace")
        where = f"on port {self.port}" if self.port else "on a port of the OS's choice"
        self.stop()
        raise EndpointError(f"roscore {where} did not come up:\n{output[-2000:]}")

    def _command(self) -> list[str]:
        """`roscore -p PORT` for a known port, else the launcher that lets the OS choose."""
        if self.port:
            return ["roscore", "-p", str(self.port)]
        rosmaster = shutil.which("rosmaster") or "rosmaster"
        first = Path(rosmaster).read_text(errors="replace").partition("\n")[0]
        python = first[2:].strip() if first.startswith("#!") else sys.executable
        return [
            *python.split(),
            str(Path(__file__).with_name("core_launch.py")),
            str(self._uri_file),
        ]

    @property
    def _uri_file(self) -> Path:
        return self.home / "master.uri"

    def _read_uri(self) -> bool:
        """Take the URI the launcher wrote, once it is there."""
        if self.uri:
            return True
        try:
            uri = self._uri_file.read_text().strip()
        except FileNotFoundError:
            return False
        port = urllib.parse.urlparse(uri).port
        if port is None:
            return False
        self.port, self.uri = port, uri
        return True

    def _launch(self, deadline: float) -> bool:
        """Run the master; True once its own master (a process of its tree) and /rosout
        answer, False when it exits or `deadline` passes first."""
        (self.home / "log").mkdir(exist_ok=True)  # rosout writes its log there
        with (self.home / "roscore.out").open("wb") as log:
            process = self._process = subprocess.Popen(
                self._command(),
                env=self.env,
                stdout=log,
                stderr=subprocess.STDOUT,
                stdin=subprocess.DEVNULL,
                start_new_session=True,
            )
        ours = False
        while time.monotonic() < deadline and process.poll() is None:
            if not self._read_uri():
                time.sleep(0.05)
                continue
            master = xmlrpc.client.ServerProxy(self.uri)
            with contextlib.suppress(OSError, xmlrpc.client.Error):
                if not ours:
                    reply: Any = master.getPid(_CALLER)
                    tree = {process.pid, *(pid for pid, _ in _descendants(process.pid))}
                    ours = reply[0] == 1 and reply[2] in tree
                if ours:
                    reply = master.getSystemState(_CALLER)
                    code, _, state = reply
                    publishers = state[0] if code == 1 else []
                    if any(topic == "/rosout_agg" for topic, _ in publishers):
                        return True
            time.sleep(0.1)
        return False

    def stop_process(self) -> None:
        """Kill roscore's process tree (ROS_HOME stays)."""
        if self._process is not None:
            terminate(self._process)
            self._process = None

    def stop(self) -> None:
        """Kill roscore's whole process tree and remove ROS_HOME."""
        self.stop_process()
        shutil.rmtree(self.home, ignore_errors=True)

    def kill(self) -> None:
        """Crash the master: SIGKILL roscore, rosmaster and rosout at once, no cleanup.
        ROS_HOME stays, so `start()` may bring a new master up on the same port."""
        if self._process is None:
            return
        for pid in [self._process.pid, *(pid for pid, _ in _descendants(self._process.pid))]:
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signal.SIGKILL)
        self._process.wait()
        self._process = None

    def __enter__(self) -> RosCore:
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

    def spawn(self, args: Sequence[str]) -> DrainedProcess:
        """Start a ROS process against this master in its own session (stop with terminate).
        Its output is read all the time (`DrainedProcess`), so it never blocks on a full pipe;
        `output()` gives what it wrote so far."""
        return DrainedProcess(args, self.env)

    @contextlib.contextmanager
    def running(self, args: Sequence[str]) -> Iterator[DrainedProcess]:
        """`spawn` that always terminates the process on exit."""
        process = self.spawn(args)
        try:
            yield process
        finally:
            terminate(process)
