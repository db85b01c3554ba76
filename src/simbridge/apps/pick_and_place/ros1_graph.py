"""The ROS 1 side of the demo: a master (reused or a private roscore) and the planner node.

The master is a DemoMaster: ROS_MASTER_URI if one answers there, else a private roscore
that this process's environment points at until stop(). The planner runs as its own
rospy node process (`simbridge planner`: rospy allows one node per process, and this
process's node is the endpoint's) under a unique node name, so it never shuts down a
planner the user already runs. It counts as up when its own node answers a probe on
/niryo_moveit: a stale registration left by a dead planner does not.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import IO

from simbridge.apps.pick_and_place.planner_node import NODE_NAME, PLANNER_SERVICE
from simbridge.apps.pick_and_place.scene import SCENE_PATH
from simbridge.apps.ros_master import DemoMaster
from simbridge.endpoint.backends.ros1 import terminate, unique_node_name
from simbridge.errors import AppError, EndpointError

__all__ = ["Ros1Graph"]


class Ros1Graph:
    """A reachable ROS master plus the planner node serving /niryo_moveit; a context manager."""

    def __init__(self, scene_path: Path = SCENE_PATH, startup_timeout: float = 30.0) -> None:
        self.scene_path = scene_path
        self.startup_timeout = startup_timeout
        self.master = DemoMaster(startup_timeout)
        self.planner_node = f"/{unique_node_name(NODE_NAME)}"
        self._home: Path | None = None
        self._planner: subprocess.Popen[bytes] | None = None
        self._planner_log: IO[bytes] | None = None

    def start(self) -> Ros1Graph:
        """Make sure a master answers, then start the planner node and wait for its service."""
        try:
            self.master.start()
            self._start_planner()
        except BaseException:
            self.stop()
            raise
        return self

    def _start_planner(self) -> None:
        from simbridge.endpoint.backends.ros1 import (  # noqa: PLC0415 - ROS is optional
            probe_service,
        )

        log_dir = self._home or Path(tempfile.mkdtemp(prefix="simbridge-pick-and-place-"))
        self._home = log_dir
        self._planner_log = (log_dir / "planner_node.out").open("w+b")
        self._planner = subprocess.Popen(
            [
                *(sys.executable, "-m", "simbridge.cli", "planner", "--backend", "ros1"),
                *("--node-name", self.planner_node, "--scene", str(self.scene_path)),
            ],
            stdout=self._planner_log,
            stderr=subprocess.STDOUT,
            stdin=subprocess.DEVNULL,
            start_new_session=True,
        )
        deadline = time.monotonic() + self.startup_timeout
        while True:
            try:
                if probe_service(self.master.uri, PLANNER_SERVICE) == self.planner_node:
                    return
            except EndpointError as exc:
                why = str(exc)
            else:
                why = f"{PLANNER_SERVICE} is served by another node"
            if self._planner.poll() is not None or time.monotonic() > deadline:
                raise AppError(
                    f"the planner node {self.planner_node} did not offer {PLANNER_SERVICE} on "
                    f"{self.master.uri} ({why}):\n{self.planner_output()[-2000:]}"
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
            terminate(self._planner)
            self._planner = None
        if self._planner_log is not None:
            self._planner_log.close()
            self._planner_log = None
        self.master.stop()
        if self._home is not None:
            shutil.rmtree(self._home, ignore_errors=True)
            self._home = None

    def __enter__(self) -> Ros1Graph:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()
