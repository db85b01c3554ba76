"""The command line, run in-process against a live endpoint."""

from __future__ import annotations

import threading
from collections.abc import Iterator

import pytest

from simbridge.cli import build_parser, main
from simbridge.endpoint import EndpointOptions, EndpointThread, LocalBus, Node
from simbridge.messages import default_registry


@pytest.fixture
def endpoint() -> Iterator[EndpointThread]:
    with EndpointThread(EndpointOptions(port=0)) as ep:
        yield ep


def test_msg_md5_prints_only_the_md5(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["msg", "md5", "sensor_msgs/Image"]) == 0
    assert capsys.readouterr().out == "060021388200f6f0f447d0fcd9c64743\n"


def test_msg_show_nested(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["msg", "show", "geometry_msgs/Twist"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("geometry_msgs/Vector3 linear\n  float64 x\n")


def test_unknown_type_is_a_clear_error(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["msg", "md5", "sensor_msgs/Imagee"]) == 2
    err = capsys.readouterr().err
    assert "sensor_msgs/Imagee" in err
    assert "sensor_msgs/Image" in err


def test_topic_pub_reaches_echo(
    endpoint: EndpointThread, capsys: pytest.CaptureFixture[str]
) -> None:
    address = f"127.0.0.1:{endpoint.port}"
    result: list[int] = []
    echo = threading.Thread(
        target=lambda: result.append(
            main(
                [
                    "topic",
                    "echo",
                    "/cmd_vel",
                    "--type",
                    "geometry_msgs/Twist",
                    "-n",
                    "1",
                    "--duration",
                    "10",
                    "--endpoint",
                    address,
                ]
            )
        )
    )
    echo.start()
    bus = endpoint.backend
    assert isinstance(bus, LocalBus)
    # Publish until the echo tool's subscription is in place and it exits.
    for _ in range(50):
        main(
            [
                "topic",
                "pub",
                "/cmd_vel",
                "geometry_msgs/Twist",
                "{linear: {x: 0.5}}",
                "--endpoint",
                address,
            ]
        )
        echo.join(0.2)
        if not echo.is_alive():
            break
    assert result == [0]
    out = capsys.readouterr().out
    assert "linear: {x: 0.5, y: 0.0, z: 0.0}" in out


def test_topic_list_verbose(endpoint: EndpointThread, capsys: pytest.CaptureFixture[str]) -> None:
    assert isinstance(endpoint.backend, LocalBus)
    with Node(endpoint.backend, "/n") as node:
        node.advertise("/odom", "nav_msgs/Odometry")
        assert main(["topic", "list", "-v", "--endpoint", f"127.0.0.1:{endpoint.port}"]) == 0
    assert "/odom  nav_msgs/Odometry" in capsys.readouterr().out


def test_service_call(endpoint: EndpointThread, capsys: pytest.CaptureFixture[str]) -> None:
    reg = default_registry()
    assert isinstance(endpoint.backend, LocalBus)
    with Node(endpoint.backend, "/n") as node:
        node.serve(
            "/enable",
            "std_srvs/SetBool",
            lambda req: reg.new("std_srvs/SetBoolResponse", success=req.data, message="ok"),
        )
        code = main(
            [
                "service",
                "call",
                "/enable",
                "std_srvs/SetBool",
                "{data: true}",
                "--endpoint",
                f"127.0.0.1:{endpoint.port}",
            ]
        )
    assert code == 0
    out = capsys.readouterr().out
    assert "success: true" in out
    assert "message: ok" in out


def test_service_call_without_provider_fails_fast(
    endpoint: EndpointThread, capsys: pytest.CaptureFixture[str]
) -> None:
    code = main(
        [
            "service",
            "call",
            "/absent",
            "std_srvs/Trigger",
            "--endpoint",
            f"127.0.0.1:{endpoint.port}",
        ]
    )
    assert code == 2
    assert "no provider" in capsys.readouterr().err


def test_bad_endpoint_address() -> None:
    with pytest.raises(SystemExit):
        main(["topic", "list", "--endpoint", "nowhere"])


ARM_URDF = """<robot name="two_link">
  <link name="base"/>
  <link name="upper"><inertial><mass value="1"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="tip"/>
  <joint name="shoulder" type="revolute">
    <parent link="base"/><child link="upper"/>
    <origin xyz="0 0 0.5"/><axis xyz="0 1 0"/>
    <limit lower="-2" upper="2" effort="10" velocity="1"/>
  </joint>
  <joint name="wrist" type="fixed">
    <parent link="upper"/><child link="tip"/><origin xyz="0.3 0 0"/>
  </joint>
</robot>"""


def test_urdf_fk_json_matches_hand_computed(tmp_path, capsys: pytest.CaptureFixture[str]) -> None:
    import json
    import math

    path = tmp_path / "arm.urdf"
    path.write_text(ARM_URDF)
    assert main(["urdf", "fk", str(path), "--set", "shoulder=0.5", "--json"]) == 0
    poses = json.loads(capsys.readouterr().out)
    # Rotation of 0.5 rad about +y: the tip at (0.3, 0, 0) goes to (0.3 cos, 0, -0.3 sin).
    assert poses["tip"]["xyz"] == pytest.approx(
        [0.3 * math.cos(0.5), 0, 0.5 - 0.3 * math.sin(0.5)], abs=1e-6
    )
    assert poses["tip"]["quat_xyzw"] == pytest.approx(
        [0, math.sin(0.25), 0, math.cos(0.25)], abs=1e-6
    )
    assert poses["base"]["xyz"] == [0, 0, 0]


def test_urdf_check_and_error(tmp_path, capsys: pytest.CaptureFixture[str]) -> None:
    good = tmp_path / "arm.urdf"
    good.write_text(ARM_URDF)
    assert main(["urdf", "check", str(good)]) == 0
    assert "shoulder" in capsys.readouterr().out
    bad = tmp_path / "bad.urdf"
    bad.write_text(ARM_URDF.replace('<parent link="upper"/>', '<parent link="nowhere"/>'))
    assert main(["urdf", "check", str(bad)]) == 2
    assert "nowhere" in capsys.readouterr().err


def test_sim_runs_a_scene_for_a_duration(tmp_path, capsys: pytest.CaptureFixture[str]) -> None:
    urdf = tmp_path / "arm.urdf"
    urdf.write_text(ARM_URDF)
    scene = tmp_path / "scene.yaml"
    scene.write_text(f"robots:\n  - name: arm\n    urdf: {urdf}\n")
    assert main(["sim", str(scene), "--duration", "0.5"]) == 0
    assert "simulated 0.5" in capsys.readouterr().out


def test_demo_pick_and_place_json_last_line(capsys: pytest.CaptureFixture[str]) -> None:
    import json

    assert main(["demo", "--json", "--seed", "1"]) == 0
    summary = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert summary["success"] is True
    assert summary["cube_error_m"] < 0.02
    assert [p["name"] for p in summary["phases"]][:3] == ["settle", "plan", "pre_grasp"]


def test_demo_bridge(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["demo", "bridge"]) == 0
    assert "5/5 messages delivered" in capsys.readouterr().out


def test_msg_genpy_writes_importable_modules(tmp_path, capsys: pytest.CaptureFixture[str]) -> None:
    import subprocess

    assert main(["msg", "genpy", str(tmp_path), "niryo_moveit/MoverService"]) == 0
    exports = capsys.readouterr().out
    assert f"PYTHONPATH={tmp_path}/python" in exports
    probe = "import niryo_moveit.srv as s; print(s.MoverService._md5sum)"
    done = subprocess.run(
        ["/usr/bin/python3", "-c", probe],
        env={"PYTHONPATH": f"{tmp_path}/python"},
        capture_output=True,
        text=True,
        check=True,
    )
    assert done.stdout.strip() == default_registry().md5("niryo_moveit/MoverService")


def test_endpoint_refuses_a_busy_poll_time_out_of_range(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["endpoint", "--port", "0", "--busy-poll-us", "-5"]) == 2
    assert "busy-poll time -5.0 µs is out of range: expected 0 to 100000" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("given", "limit"),
    [
        (["--backend", "ros1"], 500e-6),  # on by default where rospy nodes answer
        (["--backend", "ros1", "--busy-poll-us", "2000"], 2000e-6),
        (["--backend", "ros1", "--busy-poll-us", "0"], None),
        (["--backend", "local"], None),
        (["--backend", "local", "--busy-poll-us", "300"], 300e-6),
        (["--backend", "ros2"], None),
    ],
)
def test_endpoint_busy_poll_defaults_on_for_ros1_alone(
    given: list[str], limit: float | None
) -> None:
    from simbridge.cli.endpoint import busy_poll_selector

    selector = busy_poll_selector(build_parser().parse_args(["endpoint", *given]))
    if limit is None:
        assert selector is None
    else:
        assert selector is not None
        assert selector.limit == pytest.approx(limit)
        selector.close()


@pytest.mark.parametrize(("given", "splice"), [([], True), (["--no-splice"], False)])
def test_endpoint_splices_large_messages_unless_told_not_to(given: list[str], splice: bool) -> None:
    from simbridge.cli.endpoint import endpoint_options

    options = endpoint_options(build_parser().parse_args(["endpoint", *given]), None, 0)
    assert options.splice is splice
    assert options.host == "127.0.0.1"
    assert options.port == 0


@pytest.mark.parametrize(("given", "bound"), [([], 5.0), (["--drain-timeout", "0.5"], 0.5)])
def test_endpoint_drain_bound_comes_from_the_command_line(given: list[str], bound: float) -> None:
    from simbridge.cli.endpoint import endpoint_options

    options = endpoint_options(build_parser().parse_args(["endpoint", *given]), None, 0)
    assert options.drain_timeout == bound
