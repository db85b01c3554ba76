"""Test support for Ray: real clusters on loopback (a head and a second node), never mocks.

Every cluster here runs with a private RAY_TMPDIR (its sessions, sockets, logs and the
address `--ray auto` reads), usage stats off, no dashboard, a 100 MB object store per
node and one CPU per node (the CI machine has two cores); it is stopped, and its folder
removed, when the block ends.

Loopback address: Ray 2.60 turns 127.0.0.1 and localhost, in `ray.init(address=...)` and
in `ray start --address/--node-ip-address`, into the machine's routed IP
(ray-project/ray#59110), where a node bound to loopback does not answer. Any other
127/8 address is loopback on Linux too and Ray keeps it as given: the clusters here
bind 127.0.0.2.
"""

from __future__ import annotations

import contextlib
import importlib
import importlib.util
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pytest

__all__ = [
    "LOOPBACK",
    "OBJECT_STORE_BYTES",
    "RAY_BIN",
    "RayProcesses",
    "descendants_named",
    "local_cluster",
    "ray_environment",
    "require_ray",
]

LOOPBACK = "127.0.0.2"
OBJECT_STORE_BYTES = 100 * 1000 * 1000
RAY_BIN = Path(sys.executable).with_name("ray")
START_TIMEOUT_S = 120.0


def require_ray() -> Any:
    """The `ray` module; skip without it, except on CI (env CI set), where that fails."""
    if importlib.util.find_spec("ray") is not None:
        return importlib.import_module("ray")
    if os.environ.get("CI"):
        pytest.fail("Ray is not installed on CI: `make test` installs simbridge[ray]")
    pytest.skip("Ray is not installed (pip install 'simbridge[ray]')")


@contextmanager
def ray_environment() -> Iterator[dict[str, str]]:
    """os.environ set for private Ray clusters for the block (and restored after); yields
    that environment, for subprocesses."""
    folder = tempfile.mkdtemp(prefix="sbray", dir="/tmp")  # short: Ray's socket paths
    settings = {
        "RAY_TMPDIR": folder,
        "RAY_USAGE_STATS_ENABLED": "0",
        "RAY_GRACEFUL_SHUTDOWN_DRAIN_TIMEOUT_S": "0",  # stop at once, not after 30 s
    }
    saved = {key: os.environ.get(key) for key in settings}
    os.environ.update(settings)
    try:
        yield dict(os.environ)
    finally:
        for key, value in saved.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value
        shutil.rmtree(folder, ignore_errors=True)


@contextmanager
def local_cluster(nodes: int = 2) -> Iterator[Any]:
    """`ray.cluster_utils.Cluster`: a head and `nodes - 1` more, one CPU each, this
    process connected to it as the driver."""
    ray = require_ray()
    cluster_utils = importlib.import_module("ray.cluster_utils")
    node_args = {
        "num_cpus": 1,
        "object_store_memory": OBJECT_STORE_BYTES,
        "node_ip_address": LOOPBACK,
    }
    with ray_environment():
        cluster = cluster_utils.Cluster(
            initialize_head=True, head_node_args={**node_args, "include_dashboard": False}
        )
        try:
            for _ in range(nodes - 1):
                cluster.add_node(**node_args)
            ray.init(address=cluster.address, logging_level="WARNING")
            cluster.wait_for_nodes()
            yield cluster
        finally:
            ray.shutdown()
            cluster.shutdown()


def descendants_named(prefix: str, root: int | None = None) -> list[int]:
    """Processes under `root` (default: this one), at any depth, whose command line starts
    with `prefix` (Ray names a worker "ray::CLASS" or "ray::CLASS.METHOD")."""
    parents: dict[int, int] = {}
    names: dict[int, str] = {}
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
            names[int(entry.name)] = (entry / "cmdline").read_bytes().decode(errors="replace")
        except OSError:  # gone meanwhile
            continue
        parents[int(entry.name)] = int(stat.rsplit(")", 1)[1].split()[1])
    under = {os.getpid() if root is None else root}
    grew = True
    while grew:
        found = {pid for pid, parent in parents.items() if parent in under} - under
        under |= found
        grew = bool(found)
    return sorted(pid for pid in under if names.get(pid, "").startswith(prefix))


class RayProcesses:
    """`ray start --block` processes, each in a session of its own, stopped as groups
    (`ray stop` would stop every Ray process of this user on the machine)."""

    def __init__(self, env: dict[str, str], folder: Path) -> None:
        self.env, self.folder = env, folder
        self.running: list[subprocess.Popen[bytes]] = []

    def start_head(self, *args: str) -> str:
        """`ray start --head ARGS` (give it `--port=0`); its address, once it has one."""
        head = self.start("head", "--head", *args)
        recorded = self.folder / "ray" / "ray_current_cluster"  # under RAY_TMPDIR
        self.wait_for("head", head, lambda: recorded.exists() and bool(recorded.read_text()))
        return recorded.read_text().strip()

    def start_node(self, *args: str) -> None:
        """`ray start ARGS` (with the head's `--address=`), once the node runs."""
        name = f"node{len(self.running)}"
        node = self.start(name, *args)
        self.wait_for(name, node, lambda: "Ray runtime started" in self.log(name))

    def __enter__(self) -> RayProcesses:
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def start(self, name: str, *args: str) -> subprocess.Popen[bytes]:
        """`ray start --block ARGS`, its output in FOLDER/NAME.log."""
        with (self.folder / f"{name}.log").open("wb") as log:
            process = subprocess.Popen(
                [str(RAY_BIN), "start", "--block", *args],
                env=self.env,
                stdout=log,
                stderr=subprocess.STDOUT,
                start_new_session=True,
            )
        self.running.append(process)
        return process

    def log(self, name: str) -> str:
        """What process NAME printed so far."""
        return (self.folder / f"{name}.log").read_text(errors="replace")

    def wait_for(
        self, name: str, process: subprocess.Popen[bytes], done: Callable[[], bool]
    ) -> None:
        """Until `done()`; fails with the process's log if it exits or takes too long."""
        deadline = time.monotonic() + START_TIMEOUT_S
        while not done():
            assert process.poll() is None, self.log(name)
            assert time.monotonic() < deadline, self.log(name)
            time.sleep(0.1)

    def stop(self) -> None:
        """SIGTERM to every group, SIGKILL to what is left after 30 s (idempotent)."""
        for process in reversed(self.running):
            if process.poll() is None:
                os.killpg(process.pid, signal.SIGTERM)
        for process in reversed(self.running):
            try:
                process.wait(30)
            except subprocess.TimeoutExpired:
                os.killpg(process.pid, signal.SIGKILL)
                process.wait()
            with contextlib.suppress(ProcessLookupError):  # what it left in its session
                os.killpg(process.pid, signal.SIGKILL)
        self.running.clear()
