"""`simbridge urdf check|fk` and `simbridge sim` take xacro args (NAME:=VALUE or --arg),
report unknown ones, honour --strict and print load warnings as `simbridge: warning: ...`."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from simbridge.cli import main

# A small xacro file with args, as robot descriptions (a Panda with `hand:=true`) have.
HAND_XACRO = """<?xml version="1.0"?>
<robot name="arm" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:arg name="hand" default="false"/>
  <xacro:arg name="reach" default="0.5"/>
  <link name="base_link"/>
  <link name="arm_link">
    <inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01"/></inertial>
  </link>
  <joint name="shoulder" type="revolute">
    <parent link="base_link"/><child link="arm_link"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="100" velocity="1"/>
  </joint>
  <xacro:if value="$(arg hand)">
    <link name="hand_link"/>
    <joint name="hand_joint" type="fixed">
      <parent link="arm_link"/><child link="hand_link"/>
      <origin xyz="0 0 $(arg reach)"/>
    </joint>
  </xacro:if>
</robot>
"""

DUPLICATE = """<robot name="dup">
  <link name="a"/>
  <link name="a"/>
</robot>
"""


@pytest.fixture
def xacro_file(tmp_path: Path) -> Path:
    path = tmp_path / "arm.urdf.xacro"
    path.write_text(HAND_XACRO)
    return path


@pytest.mark.parametrize("style", ["ros", "option"])
def test_urdf_check_takes_xacro_args(
    xacro_file: Path, capsys: pytest.CaptureFixture[str], style: str
) -> None:
    assert main(["urdf", "check", str(xacro_file)]) == 0
    assert "hand_link" not in capsys.readouterr().out
    words = ["hand:=true"] if style == "ros" else ["--arg", "hand=true"]
    assert main(["urdf", "check", str(xacro_file), *words]) == 0
    assert "hand_link" in capsys.readouterr().out


def test_urdf_fk_takes_xacro_args(xacro_file: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["urdf", "fk", str(xacro_file), "hand:=true", "reach:=0.7", "--json"]) == 0
    poses = json.loads(capsys.readouterr().out)
    assert poses["hand_link"]["xyz"] == pytest.approx([0.0, 0.0, 0.7])


def test_unknown_xacro_arg_is_an_error(
    xacro_file: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["urdf", "check", str(xacro_file), "hnd:=true"]) == 2
    err = capsys.readouterr().err
    assert err.strip() == (
        f"simbridge: error: {xacro_file}: unknown xacro arg(s) hnd (the file declares: hand, reach)"
    )


def test_xacro_args_on_a_plain_urdf_are_an_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "plain.urdf"
    path.write_text("<robot name='r'><link name='a'/></robot>")
    assert main(["urdf", "fk", str(path), "--arg", "hand=true"]) == 2
    assert "xacro args hand given, but the file is not xacro" in capsys.readouterr().err


def test_find_failure_is_one_plain_message(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "r.xacro"
    path.write_text(
        '<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">'
        '<xacro:include filename="$(find nopkg)/x.xacro"/><link name="a"/></robot>'
    )
    assert main(["urdf", "check", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"simbridge: error: {path}: xacro: $(find nopkg): package 'nopkg' not")
    assert "class" not in err
    assert err.count("not found") == 1


def test_sim_takes_xacro_args_and_reports_unknown(
    xacro_file: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    scene = tmp_path / "scene.yaml"
    scene.write_text(f"robots:\n  - urdf: {xacro_file}\n")
    run = ["sim", str(scene), "--duration", "0.01", "--realtime", "0"]
    assert main([*run, "hand:=true"]) == 0
    assert main([*run, "--arg", "hnd=1"]) == 2
    assert "unknown xacro arg(s) hnd" in capsys.readouterr().err


def test_warnings_print_plainly_and_strict_refuses(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "dup.urdf"
    path.write_text(DUPLICATE)
    assert main(["urdf", "fk", str(path)]) == 0
    err = capsys.readouterr().err
    assert err == (
        f"simbridge: warning: {path}:3: link 'a' is defined twice; "
        "keeping the first definition (line 2)\n"
    )
    assert main(["urdf", "check", str(path)]) == 0
    captured = capsys.readouterr()
    assert captured.err == ""  # listed in the report instead, once
    assert captured.out.count("defined twice") == 1
    assert main(["urdf", "check", str(path), "--strict"]) == 2
    assert "strict mode" in capsys.readouterr().err
    scene = tmp_path / "scene.yaml"
    scene.write_text(f"robots:\n  - urdf: {path}\n")
    assert main(["sim", str(scene), "--duration", "0.01", "--realtime", "0"]) == 0
    err = capsys.readouterr().err
    assert err.startswith(f"simbridge: warning: {path}:3: link 'a' is defined twice")
    assert "UrdfWarning" not in err
    assert "warnings.warn" not in err
    assert main(["sim", str(scene), "--duration", "0.01", "--realtime", "0", "--strict"]) == 2
    assert "defined twice" in capsys.readouterr().err
