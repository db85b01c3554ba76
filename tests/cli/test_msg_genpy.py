"""`simbridge msg genpy` output makes the real `rosmsg show` / `rossrv show` / `rosmsg md5`
work for custom types, even when a same-named system package without .msg files exists."""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import pytest

from simbridge.cli import main
from simbridge.messages import MessageRegistry

_MSG = "std_msgs/Header header\ngeometry_msgs/Pose[] poses\nduration wait\nuint8 MODE=3\n"
_SRV = "demo_tools/Target goal\nbool dry_run\n---\ngeometry_msgs/PoseStamped result\n"


@pytest.fixture
def custom(tmp_path: Path) -> Path:
    if not (shutil.which("rosmsg") and shutil.which("rossrv")):
        if os.environ.get("CI"):
            pytest.fail("rosmsg/rossrv are not installed on CI: run `make sysdeps`")
        pytest.skip("rosmsg/rossrv (python3-rosmsg) are not installed")
    package = tmp_path / "defs" / "demo_tools"
    (package / "msg").mkdir(parents=True)
    (package / "srv").mkdir()
    (package / "msg" / "Target.msg").write_text(_MSG)
    (package / "srv" / "Plan.srv").write_text(_SRV)
    return tmp_path


def _ros_env(exports: str, tmp_path: Path) -> dict[str, str]:
    """The environment after the printed `export` lines, on top of a system package path
    holding a decoy geometry_msgs without .msg files (as a ROS install may have)."""
    decoy = tmp_path / "system" / "geometry_msgs"
    decoy.mkdir(parents=True)
    (decoy / "package.xml").write_text(
        '<?xml version="1.0"?><package format="2"><name>geometry_msgs</name><version>1.0.0'
        "</version><description>d</description><maintainer email='a@b.c'>a</maintainer>"
        "<license>BSD</license></package>"
    )
    env = {
        "PATH": os.environ.get("PATH", "/usr/bin:/bin"),
        "ROS_HOME": str(tmp_path / "ros_home"),
        "ROS_PACKAGE_PATH": str(tmp_path / "system"),
        "PYTHONPATH": "",
    }
    for line in exports.splitlines():
        key, _, value = line.removeprefix("export ").partition("=")
        env[key] = value.replace(f"${key}", env[key]).rstrip(":")
    return env


def _tool(env: dict[str, str], *args: str) -> str:
    done = subprocess.run(args, env=env, capture_output=True, text=True, timeout=60, check=False)
    assert done.returncode == 0, f"{' '.join(args)} failed:\n{done.stdout}\n{done.stderr}"
    return done.stdout


def test_rosmsg_and_rossrv_show_generated_types(
    custom: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out, defs = custom / "gen", str(custom / "defs")
    types = ["demo_tools/Plan", "demo_tools/Target", "--msg-path", defs]
    assert main(["msg", "genpy", str(out), *types]) == 0
    env = _ros_env(capsys.readouterr().out, custom)
    assert env["ROS_PACKAGE_PATH"].startswith(f"{out}/src:")

    registry = MessageRegistry()
    registry.load_packages(defs)
    shown = _tool(env, "rossrv", "show", "demo_tools/Plan")
    assert shown.strip() == registry.show("demo_tools/Plan").strip()
    assert "geometry_msgs/PoseStamped result\n  std_msgs/Header header\n" in shown
    assert _tool(env, "rosmsg", "show", "demo_tools/Target").strip() == (
        registry.show("demo_tools/Target").strip()
    )
    assert _tool(env, "rosmsg", "show", "geometry_msgs/Pose").startswith(
        "geometry_msgs/Point position\n"
    )
    assert _tool(env, "rossrv", "md5", "demo_tools/Plan").strip() == registry.md5("demo_tools/Plan")
    assert _tool(env, "rosmsg", "md5", "demo_tools/Target").strip() == registry.md5(
        "demo_tools/Target"
    )
