"""Network discipline: ROS 2 traffic of the endpoint and the test nodes stays on loopback.

The check runs in a private network namespace (`unshare -rn`) with a veth pair that
has an address and a multicast route, and compares that interface's transmit
counters in /proc/net/dev before and after the endpoint, a ROS 2 subscriber and a
ROS 2 publisher exchanged messages. The control run, one node with DDS defaults,
shows the check can fail: it does send on the veth.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from tests.ros2support import require_ros2

pytestmark = [pytest.mark.ros2, pytest.mark.timeout(180)]

ROOT = Path(__file__).resolve().parents[2]


def in_private_netns(mode: str) -> dict[str, object]:
    require_ros2()
    if shutil.which("unshare") is None or shutil.which("ip") is None:
        pytest.skip("unshare/ip (util-linux, iproute2) are needed for a private network")
    probe = subprocess.run(["unshare", "-rn", "true"], capture_output=True, check=False)
    if probe.returncode != 0:
        pytest.skip(f"cannot create a network namespace here: {probe.stderr.decode().strip()}")
    out = subprocess.run(
        ["unshare", "-rn", sys.executable, "-m", "tests.ros2.net_driver", mode],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=150,
        check=False,
    )
    assert out.returncode == 0, out.stdout[-3000:] + out.stderr[-3000:]
    result: dict[str, object] = json.loads(out.stdout.strip().splitlines()[-1])
    return result


def test_nothing_is_sent_off_loopback() -> None:
    result = in_private_netns("endpoint")
    assert result["received"] == 6
    assert result["after"] == result["before"], "ROS 2 traffic left the loopback interface"


def test_control_dds_defaults_do_send_off_loopback() -> None:
    result = in_private_netns("control")
    before, after = result["before"], result["after"]
    assert isinstance(before, list)
    assert isinstance(after, list)
    assert after[1] > before[1], "DDS defaults sent nothing: this check could not fail"
