"""Run inside a private network namespace (`unshare -rn`) by test_multi_host.py.

Three "hosts", each a network namespace of its own nested in this private one, on one
bridge (10.213.7.0/24; no multicast route anywhere): hosts a and b each run a sim
(`simbridge sim`) and its ros2 endpoint, robot /robot_a resp. /robot_b; host c runs
multi_host_checker.py, an rclpy node that waits for both robots' joint states. Every
ROS 2 process discovers the others by unicast to the three addresses only (the Fast DDS
profile of fastdds_peers_profile_xml). Prints one JSON line: what the checker saw and
the packets each host's link carried.
"""

from __future__ import annotations

import json
import os
import queue
import re
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import yaml

from simbridge.endpoint.backends.ros2 import fastdds_peers_profile_xml, ros2_python
from tests.ros2support import child_env
from tests.sim.urdf_samples import GRAVITY_ARM

HOSTS = {"a": "10.213.7.1", "b": "10.213.7.2", "c": "10.213.7.3"}
"""The hosts of the graph: every one lists all three as its peers."""
OUTSIDER = ("d", "10.213.7.4")
"""The control: a host on the same bridge that lists only itself as peer, so (with no
multicast) it must find neither robot, started once the checker has found both."""
CHECKER = Path(__file__).parent / "multi_host_checker.py"


def sh(*command: str) -> None:
    subprocess.run(command, check=True)


class Host:
    """A network namespace held by a `sleep` process, linked to the bridge br0."""

    def __init__(self, name: str, address: str) -> None:
        self.name, self.address = name, address
        self.holder = subprocess.Popen(["unshare", "-n", "sleep", "600"])
        own = os.readlink("/proc/self/ns/net")
        deadline = time.monotonic() + 30
        while os.readlink(f"/proc/{self.holder.pid}/ns/net") == own:
            if time.monotonic() > deadline:
                raise SystemExit(f"host {name}: no network namespace after 30 s")
            time.sleep(0.01)
        link = f"h{name}"
        sh("ip", "link", "add", link, "type", "veth", "peer", "name", f"{link}br")
        sh("ip", "link", "set", link, "netns", str(self.holder.pid))
        sh("ip", "link", "set", f"{link}br", "master", "br0")
        sh("ip", "link", "set", f"{link}br", "up")
        for command in (
            ["ip", "link", "set", "lo", "up"],
            ["ip", "addr", "add", f"{address}/24", "dev", link],
            ["ip", "link", "set", link, "up"],
        ):
            sh(*self.enter(), *command)

    def enter(self) -> list[str]:
        """The command prefix that runs a program in this host's network namespace."""
        return ["nsenter", "-t", str(self.holder.pid), "-n"]

    def stop(self) -> None:
        self.holder.kill()
        self.holder.wait()


class Proc:
    """A child process whose output lines are collected; stopped with SIGINT."""

    def __init__(self, args: list[str], env: dict[str, str]) -> None:
        self.proc = subprocess.Popen(
            args,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            env=env,
            text=True,
            start_new_session=True,
        )
        self.lines: queue.Queue[str] = queue.Queue()
        self.output: list[str] = []
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self.output.append(line)
            self.lines.put(line)

    def expect(self, pattern: str, timeout: float) -> re.Match[str]:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            try:
                line = self.lines.get(timeout=0.2)
            except queue.Empty:
                if self.proc.poll() is not None and self.lines.empty():
                    break
                continue
            match = re.search(pattern, line)
            if match:
                return match
        raise SystemExit(f"no {pattern!r} (exit {self.proc.poll()}):\n" + "".join(self.output))

    def stop(self) -> None:
        if self.proc.poll() is None:
            try:
                os.killpg(self.proc.pid, signal.SIGINT)
                self.proc.wait(10)
            except subprocess.TimeoutExpired:
                os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.wait(10)
            except ProcessLookupError:
                pass


def host_env(host: Host, folder: Path, peers: list[str]) -> dict[str, str]:
    """What a user sets on each host: the peers profile and discovery range SUBNET."""
    profile = folder / f"fastdds-{host.name}.xml"
    profile.write_text(fastdds_peers_profile_xml(host.address, peers))
    env = child_env()
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "SUBNET"
    env["FASTRTPS_DEFAULT_PROFILES_FILE"] = env["FASTDDS_DEFAULT_PROFILES_FILE"] = str(profile)
    return env


def write_scene(folder: Path, robot: str) -> Path:
    (folder / "arm.urdf").write_text(GRAVITY_ARM)
    scene = {
        "robots": [{"urdf": "arm.urdf", "ros": {"namespace": f"/{robot}"}}],
        "ros": {"tf": False, "clock": False, "joint_states_rate": 20},
    }
    path = folder / f"{robot}.yaml"
    path.write_text(yaml.safe_dump(scene))
    return path


def link_packets() -> dict[str, list[int]]:
    """Packets received and sent by each host's bridge port (from /proc/net/dev)."""
    counts: dict[str, list[int]] = {}
    for line in Path("/proc/net/dev").read_text().splitlines():
        name, _, data = line.partition(":")
        name = name.strip()
        if name.startswith("h") and name.endswith("br"):
            fields = data.split()
            counts[name[1:-2]] = [int(fields[1]), int(fields[9])]
    return counts


def run(folder: Path) -> dict[str, object]:
    python = ros2_python()
    assert python is not None, "no ROS 2 venv"
    hosts = {name: Host(name, address) for name, address in (*HOSTS.items(), OUTSIDER)}
    procs: list[Proc] = []
    try:
        endpoints = {}
        for name in ("a", "b"):
            args = ["-m", "simbridge.cli", "endpoint", "--backend", "ros2", "--port", "0"]
            endpoints[name] = Proc(
                [*hosts[name].enter(), str(python), *args, "--idle-timeout", "0"],
                host_env(hosts[name], folder, list(HOSTS.values())),
            )
            procs.append(endpoints[name])
        checker = Proc(
            [*hosts["c"].enter(), str(python), str(CHECKER), "/robot_a", "/robot_b", "90"],
            host_env(hosts["c"], folder, list(HOSTS.values())),
        )
        procs.append(checker)
        for name, robot in (("a", "robot_a"), ("b", "robot_b")):
            port = endpoints[name].expect(r"listening on 127\.0\.0\.1:(\d+)", 90).group(1)
            sim = [sys.executable, "-m", "simbridge.cli", "sim", str(write_scene(folder, robot))]
            procs.append(
                Proc(
                    [*hosts[name].enter(), *sim, "--endpoint", f"127.0.0.1:{port}"],
                    dict(os.environ),
                )
            )
        seen = json.loads(checker.expect(r'^\{"seen"', 120).string)["seen"]
        packets = link_packets()
        # The control looks for 15 s while both robots are known to be on the graph.
        control = Proc(
            [*hosts["d"].enter(), str(python), str(CHECKER), "/robot_a", "/robot_b", "15"],
            host_env(hosts["d"], folder, [OUTSIDER[1]]),
        )
        procs.append(control)
        unseen = json.loads(control.expect(r'^\{"seen"', 120).string)["seen"]
        return {"seen": seen, "control": unseen, "packets": packets}
    finally:
        for proc in reversed(procs):
            proc.stop()
        for host in hosts.values():
            host.stop()


def main() -> None:
    sh("ip", "link", "set", "lo", "up")
    sh("ip", "link", "add", "br0", "type", "bridge")
    sh("ip", "link", "set", "br0", "up")
    with tempfile.TemporaryDirectory(prefix="simbridge-multihost-") as folder:
        result = run(Path(folder))
    print(json.dumps(result), flush=True)


if __name__ == "__main__":
    main()
