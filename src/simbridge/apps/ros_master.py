"""A reachable ROS 1 master for a demo run with `--backend ros1`: reused or started.

ROS_MASTER_URI is used when a master answers there; otherwise a roscore is started on a
free port with a private ROS_HOME, and this process's environment points at it (rospy
reads it from there) until stop(), which also stops that roscore (after this process's
rospy node, if it joined it, has left it).
"""

from __future__ import annotations

import os
import shutil

from simbridge.endpoint.backends.ros1 import RosCore, master_answers
from simbridge.errors import AppError, EndpointError

__all__ = ["DemoMaster"]


class DemoMaster:
    """The master a demo uses; a context manager. `uri` is set once started."""

    def __init__(self, startup_timeout: float = 30.0) -> None:
        self.startup_timeout = startup_timeout
        self.uri = ""
        self.started = False
        """Whether this object started the roscore (else it found one)."""
        self._roscore: RosCore | None = None
        self._saved_env: dict[str, str | None] = {}

    def start(self) -> DemoMaster:
        """Find the master at ROS_MASTER_URI, else start a private roscore."""
        uri = os.environ.get("ROS_MASTER_URI", "")
        if uri and master_answers(uri):
            self.uri = uri
            return self
        if shutil.which("roscore") is None:
            raise AppError(
                f"no ROS master answers at ROS_MASTER_URI={uri or '(unset)'} and roscore is "
                "not installed; install ROS 1 (roscore) or use the local backend"
            )
        roscore = RosCore()
        try:
            roscore.start(self.startup_timeout)
        except EndpointError as exc:
            raise AppError(str(exc)) from exc
        self._roscore = roscore
        self.started = True
        self.uri = roscore.uri
        hostname = {} if os.environ.get("ROS_IP") else {"ROS_HOSTNAME": "127.0.0.1"}
        self._set_env(
            ROS_MASTER_URI=roscore.uri,
            ROS_HOME=str(roscore.home),
            ROS_LOG_DIR=str(roscore.home / "log"),
            **hostname,
        )
        return self

    def _set_env(self, **values: str) -> None:
        for key, value in values.items():
            self._saved_env.setdefault(key, os.environ.get(key))
            os.environ[key] = value

    def stop(self) -> None:
        """Stop a roscore this object started and restore the environment. This process's
        node leaves that roscore first: it has no other master to serve."""
        if self._roscore is not None:
            from simbridge.endpoint.backends.ros1 import (  # noqa: PLC0415 - imports rospy
                leave_graph,
            )

            leave_graph(self.uri, "the demo's ROS master stops")
            self._roscore.stop()
            self._roscore = None
        for key, value in self._saved_env.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value
        self._saved_env.clear()

    def describe(self) -> str:
        """`URI (started)` or `URI (found)`, for progress lines."""
        return f"{self.uri} ({'started' if self.started else 'found'})"

    def __enter__(self) -> DemoMaster:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()
