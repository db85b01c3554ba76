"""`simbridge msg genpy` covers the shipped control_msgs: Debian's `rosmsg md5` (genmsg's
checksum of the generated modules) gives noetic's values for the action messages."""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import pytest

from simbridge.cli import main
from tests.messages.test_control_msgs import NOETIC_MD5


def test_rosmsg_md5_of_generated_control_msgs(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    if not shutil.which("rosmsg"):
        if os.environ.get("CI"):
            pytest.fail("rosmsg is not installed on CI: run `make sysdeps`")
        pytest.skip("rosmsg (python3-rosmsg) is not installed")
    out = tmp_path / "gen"
    types = ["control_msgs/FollowJointTrajectoryAction", "control_msgs/GripperCommandAction"]
    assert main(["msg", "genpy", str(out), *types]) == 0
    env = {"PATH": os.environ.get("PATH", "/usr/bin:/bin"), "ROS_HOME": str(tmp_path / "home")}
    env.update({"ROS_PACKAGE_PATH": "/usr/share", "PYTHONPATH": ""})
    for line in capsys.readouterr().out.splitlines():
        key, _, value = line.removeprefix("export ").partition("=")
        env[key] = value.replace(f"${key}", env[key]).rstrip(":")
    for name, md5 in NOETIC_MD5.items():
        if name == "control_msgs/JointTrajectoryControllerState":
            continue  # not an action part: not generated for these types
        done = subprocess.run(
            ["rosmsg", "md5", name], env=env, capture_output=True, text=True, timeout=60,
            check=False,
        )  # fmt: skip
        assert done.returncode == 0, done.stderr
        assert done.stdout.strip() == md5, name
