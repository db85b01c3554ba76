"""The ROS 1 side of the demo: a master (reused or a private roscore) and the planner node.

ROS_MASTER_URI is used when a master answers there; otherwise a roscore is started on a
free port with a private ROS_HOME, and this process's environment points at it until
stop(). The planner runs as its own rospy node process (rospy allows one node per process,
and this process's node is the endpoint's).
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
from pathlib import Path
from typing import IO, Any

from simbridge.apps.pick_and_place.planner_node import PLANNER_SERVICE
from simbridge.apps.pick_and_place.scene import SCENE_PATH
from simbridge.errors import AppError

__all__ = ["Ros1Graph", "master_answers"]

_CALLER = "/simbridge_pick_and_place"


def master_answers(uri: str, timeout: float = 1.0) -> bool:
    """True when a ROS master answers getPid at ``uri``."""
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


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port: int = sock.getsockname()[1]
        return port


def _stop(process: subprocess.Popen[bytes], grace: float = 5.0) -> None:
    """SIGINT the process group, then SIGKILL what is left."""
    if process.poll() is None:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(process.pid, signal.SIGINT)
        with contextlib.suppress(subprocess.TimeoutExpired):
            process.wait(grace)
    with contextlib.suppress(ProcessLookupError):
        os.killpg(process.pid, signal.SIGKILL)
    process.wait()


class Ros1Graph:
    """A reachable ROS master plus the planner node serving /niryo_moveit; a context manager."""

    def __init__(self, scene_path: Path = SCENE_PATH, startup_timeout: float = 30.0) -> None:
        self.scene_path = scene_path
        self.startup_timeout = startup_timeout
        self.master_uri = ""
        self.started_master = False
        self._home: Path | None = None
        self._roscore: subprocess.Popen[bytes] | None = None
        self._planner: subprocess.Popen[bytes] | None = None
        self._planner_log: IO[bytes] | None = None
        self._saved_env: dict[str, str | None] = {}

    def start(self) -> Ros1Graph:
        """Make sure a master answers, then start the planner node and wait for its service."""
        try:
            self._ensure_master()
            self._start_planner()
        except BaseException:
            self.stop()
            raise
        return self

    def _ensure_master(self) -> None:
        uri = os.environ.get("ROS_MASTER_URI", "")
        if uri and master_answers(uri):
            self.master_uri = uri
            return
        if shutil.which("roscore") is None:
            raise AppError(
                f"no ROS master answers at ROS_MASTER_URI={uri or '(unset)'} and roscore is "
                "not installed; install ROS 1 (roscore) or use the local backend"
            )
        port = _free_port()
        self._home = Path(tempfile.mkdtemp(prefix="simbridge-pick-and-place-ros-"))
        self.master_uri = f"http://127.0.0.1:{port}/"
        hostname = {} if os.environ.get("ROS_IP") else {"ROS_HOSTNAME": "127.0.0.1"}
        self._set_env(
            ROS_MASTER_URI=self.master_uri,
            ROS_HOME=str(self._home),
            ROS_LOG_DIR=str(self._home / "log"),
            **hostname,
        )
        with (self._home / "roscore.out").open("wb") as out:
            self._roscore = subprocess.Popen(
                ["roscore", "-p", str(port)],
                stdout=out,
                stderr=subprocess.STDOUT,
                stdin=subprocess.DEVNULL,
                start_new_session=True,
            )
        self.started_master = True
        deadline = time.monotonic() + self.startup_timeout
        while not master_answers(self.master_uri):
            if self._roscore.poll() is not None or time.monotonic() > deadline:
                output = (self._home / "roscore.out").read_text(errors="replace")
                raise AppError(f"roscore on port {port} did not come up:\n{output[-2000:]}")
            time.sleep(0.1)

    def _set_env(self, **values: str) -> None:
        for key, value in values.items():
            self._saved_env.setdefault(key, os.environ.get(key))
            os.environ[key] = value

    def _start_planner(self) -> None:
        log_dir = self._home or Path(tempfile.mkdtemp(prefix="simbridge-pick-and-place-"))
        self._home = log_dir
        self._planner_log = (log_dir / "planner_node.out").open("w+b")
        self._planner = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "simbridge.apps.pick_and_place.ros1_planner",
                "--scene",
                str(self.scene_path),
            ],
            stdout=self._planner_log,
            stderr=subprocess.STDOUT,
            stdin=subprocess.DEVNULL,
            start_new_session=True,
        )
        master = xmlrpc.client.ServerProxy(self.master_uri)
        deadline = time.monotonic() + self.startup_timeout
        while True:
            reply: Any = master.lookupService(_CALLER, PLANNER_SERVICE)
            if reply[0] == 1:
                return
            if self._planner.poll() is not None or time.monotonic() > deadline:
                raise AppError(
                    f"the planner node did not offer {PLANNER_SERVICE} on {self.master_uri}:\n"
                    f"{self.planner_output()[-2000:]}"
                )
            time.sleep(0.1)

    def planner_output(self) -> str:
        """What the planner node printed so far."""
        if self._planner_log is None:
            return ""
        self._planner_log.flush()
        self._planner_log.seek(0)
        return self._planner_log.read().decode(errors="replace")

    def stop(self) -> None:
        """Stop the planner node and a roscore this object started; restore the environment."""
        if self._planner is not None:
            _stop(self._planner)
            self._planner = None
        if self._planner_log is not None:
            self._planner_log.close()
            self._planner_log = None
        if self._roscore is not None:
            _stop(self._roscore)
            self._roscore = None
        for key, value in self._saved_env.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value
        self._saved_env.clear()
        if self._home is not None:
            shutil.rmtree(self._home, ignore_errors=True)
            self._home = None

    def __enter__(self) -> Ros1Graph:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()
