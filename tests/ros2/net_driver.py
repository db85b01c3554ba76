"""Run inside a private network namespace (`unshare -rn`) by test_ros2_network.py.

The namespace has loopback plus a veth pair with an address and a multicast route,
so a DDS participant that ignored the localhost-only settings would send there.
Modes:
    endpoint  the ros2 endpoint + helper nodes, a client publishing and subscribing
    control   one helper node with DDS defaults (discovery range SUBNET, no profile)
Prints one JSON line: the veth's transmit counters before and after, and what arrived.
"""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

from simbridge.protocol import (
    MessageReceived,
    ProtocolConnection,
    Publish,
    Subscribe,
)
from tests.endpoint.rawclient import RawClient
from tests.ros2support import Ros2Process, child_env, start_endpoint

SETUP = [
    "sysctl -qw net.ipv6.conf.all.disable_ipv6=1",
    "sysctl -qw net.ipv6.conf.default.disable_ipv6=1",
    "ip link set lo up",
    "ip link add v0 type veth peer name v1",
    "ip link set v0 multicast on",
    "ip addr add 10.200.0.1/24 dev v0",
    "ip link set v0 up",
    "ip link set v1 up",
    "ip route add 224.0.0.0/4 dev v0",
]


def tx(interface: str = "v0") -> tuple[int, int]:
    """Bytes and packets sent on `interface` (from /proc/net/dev)."""
    for line in Path("/proc/net/dev").read_text().splitlines():
        name, _, data = line.partition(":")
        if name.strip() == interface:
            fields = data.split()
            return int(fields[8]), int(fields[9])
    raise SystemExit(f"no interface {interface}")


def run_endpoint() -> dict[str, object]:
    twist = b"\x00\x01\x00\x00" + bytes(48)
    received = 0
    endpoint, port = start_endpoint("--idle-timeout", "0")
    try:
        with (
            Ros2Process.node("echo", "/net_out", "geometry_msgs/msg/Twist", "5") as echo,
            Ros2Process.node("pub", "/net_in", "std_msgs/msg/String", '{"data": "x"}', "20", "60"),
        ):
            echo.expect_json("ready")
            client = RawClient(port)
            publish = Publish("/net_out", "geometry_msgs/Twist", report_subscribers=True)
            client.send(publish.encode())
            client.send(Subscribe("/net_in", "std_msgs/String").encode())
            client.wait_subscribers(timeout=30)
            for _ in range(5):
                client.send(ProtocolConnection.message("/net_out", twist))
            for _ in range(5):
                echo.expect_json("msg")
            client.expect(lambda e: isinstance(e, MessageReceived), timeout=40)
            received = 6
            client.close()
    finally:
        endpoint.stop()
    return {"received": received}


def run_control() -> dict[str, object]:
    env = child_env()
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "SUBNET"
    env.pop("FASTRTPS_DEFAULT_PROFILES_FILE")
    env.pop("FASTDDS_DEFAULT_PROFILES_FILE")
    from tests.ros2support import NODE_SCRIPT

    with Ros2Process([str(NODE_SCRIPT), "graph", "3"], env=env) as graph:
        graph.expect_json("topics")
    return {}


def main() -> None:
    for command in SETUP:
        subprocess.run(command.split(), check=True)
    before = tx()
    result = run_endpoint() if sys.argv[1] == "endpoint" else run_control()
    time.sleep(0.5)
    print(json.dumps({"before": before, "after": tx(), **result}), flush=True)


if __name__ == "__main__":
    main()
