"""The command line, run in-process against a live endpoint."""

from __future__ import annotations

import threading
from collections.abc import Iterator

import pytest

from simbridge.cli import main
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
