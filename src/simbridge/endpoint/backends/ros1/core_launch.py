"""What `roscore` starts (a master, /rosout, the rosversion and rosdistro parameters), with
the master on a port the OS chooses: no port is picked before it is bound, so none can be
taken in between.

Run as a script by the interpreter that runs `rosmaster` (it imports nothing of
simbridge): `python3 core_launch.py URI_FILE`. The master's URI is written to
URI_FILE once it serves; SIGINT or SIGTERM stops /rosout and the master.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
import uuid
import xmlrpc.client
from pathlib import Path

__all__ = ["main"]


def _version(*args: str) -> str:
    """What `rosversion ARGS` prints, as roscore.xml sets it ('' when it cannot run)."""
    try:
        done = subprocess.run(
            ["rosversion", *args], capture_output=True, text=True, timeout=30, check=False
        )
    except (OSError, subprocess.TimeoutExpired):
        return ""
    return done.stdout.strip()


def main(argv: list[str]) -> int:
    """Serve a master and /rosout until SIGINT or SIGTERM; the URI goes to argv[1]."""
    # imported here: the module is read by tools (mypy, the architecture test) without ROS
    import roslib.packages  # noqa: PLC0415
    import rosmaster.master  # noqa: PLC0415

    if len(argv) != 2:
        print("usage: core_launch.py URI_FILE", file=sys.stderr)
        return 2
    stopped: list[int] = []  # a handler that took a lock could wait on one its own thread holds
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, lambda sig, _frame: stopped.append(sig))
    master = rosmaster.master.Master(0)
    master.start()
    uri: str = master.uri
    api = xmlrpc.client.ServerProxy(uri)
    api.setParam("/roslaunch", "/run_id", str(uuid.uuid1()))
    api.setParam("/roslaunch", "/rosversion", _version("roslaunch"))
    api.setParam("/roslaunch", "/rosdistro", _version("-d"))
    env = dict(os.environ, ROS_MASTER_URI=uri)
    rosout = subprocess.Popen(
        [*roslib.packages.find_node("rosout", "rosout"), "__name:=rosout"],
        env=env,
        stdin=subprocess.DEVNULL,
    )
    target = Path(argv[1])
    partial = target.with_name(target.name + ".partial")
    partial.write_text(uri)
    partial.replace(target)  # readers see the whole URI or nothing
    print(f"master at {uri}, /rosout pid {rosout.pid}", flush=True)
    try:
        while not stopped and master.ok():
            time.sleep(0.2)
    finally:
        rosout.terminate()
        try:
            rosout.wait(5)
        except subprocess.TimeoutExpired:
            rosout.kill()
        master.stop()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
