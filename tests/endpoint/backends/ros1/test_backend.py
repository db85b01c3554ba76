"""Ros1Backend against a real roscore and the real ROS tools (rostopic, rosservice, rospy)."""

from __future__ import annotations

import asyncio
import hashlib
import logging
import struct
import sys
import textwrap
import time
from pathlib import Path
from typing import Literal

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from tests.ros1support import (
    SYSTEM_PYTHON,
    RosMaster,
    require_ros,
    ros_string,
    until,
    with_backend,
)

from simbridge.endpoint.backends.base import TopicInfo
from simbridge.errors import EndpointError, ServiceError, UnknownMessageTypeError

require_ros(module_level=True)

import rosgraph  # noqa: E402

from simbridge.endpoint.backends.ros1 import (  # noqa: E402  # noqa: E402
    Ros1Backend,
    Ros1Options,
    Ros1Publisher,
    read_drop_in_params,
    ros_args,
)

pytestmark = [
    pytest.mark.ros1,
    pytest.mark.timeout(120),
    pytest.mark.filterwarnings("ignore:notifyAll:DeprecationWarning"),
]


STRING_HELLO = struct.pack("<I", 5) + b"hello"  # std_msgs/String data="hello"


def test_published_bytes_reach_rostopic_echo(master: RosMaster) -> None:
    async def scenario(backend: Ros1Backend) -> str:
        publisher = backend.advertise("/sb/echo", "std_msgs/String", queue_size=10, latch=False)
        with master.running(["rostopic", "echo", "-n", "1", "/sb/echo"]) as echo:
            deadline = time.monotonic() + 30
            while echo.poll() is None and time.monotonic() < deadline:
                publisher.publish(STRING_HELLO)
                await asyncio.sleep(0.1)
            out, err = echo.communicate(timeout=5)
        assert echo.returncode == 0, err
        return out

    assert with_backend(scenario).splitlines()[0] == 'data: "hello"'


def test_rostopic_pub_reaches_subscriber_as_exact_bytes(master: RosMaster) -> None:
    received: list[bytes] = []

    async def scenario(backend: Ros1Backend) -> None:
        backend.subscribe("/sb/cmd", "geometry_msgs/Twist", received.append)
        pub = ["rostopic", "pub", "-r", "10", "/sb/cmd", "geometry_msgs/Twist"]
        with master.running([*pub, "{linear: {x: 1.5, z: -2.0}, angular: {y: 0.25}}"]):
            await until(lambda: bool(received), 30, "a Twist from rostopic pub")

    with_backend(scenario)
    # Twist = 6 float64 LE: linear xyz, angular xyz; no header, no padding.
    assert received[0] == struct.pack("<6d", 1.5, 0.0, -2.0, 0.0, 0.25, 0.0)


def test_callbacks_run_on_the_event_loop_thread(master: RosMaster) -> None:
    threads: list[bool] = []

    async def scenario(backend: Ros1Backend) -> None:
        loop = asyncio.get_running_loop()

        def on_message(_: bytes) -> None:
            try:
                threads.append(asyncio.get_running_loop() is loop)
            except RuntimeError:
                threads.append(False)

        backend.subscribe("/sb/loop", "std_msgs/String", on_message)
        publisher = backend.advertise("/sb/loop", "std_msgs/String", queue_size=0, latch=False)
        while not threads:
            publisher.publish(STRING_HELLO)
            await asyncio.sleep(0.05)

    with_backend(scenario)
    assert all(threads)


def test_latched_message_reaches_late_subscriber(master: RosMaster) -> None:
    async def scenario(backend: Ros1Backend) -> str:
        publisher = backend.advertise("/sb/latched", "std_msgs/String", queue_size=1, latch=True)
        publisher.publish(ros_string("latched once"))
        await asyncio.sleep(0.2)
        echo = await asyncio.to_thread(
            master.run, ["rostopic", "echo", "-n", "1", "/sb/latched"], 30
        )
        assert echo.returncode == 0, echo.stderr
        return echo.stdout

    assert with_backend(scenario).splitlines()[0] == 'data: "latched once"'


def test_type_without_python_module_round_trips(master: RosMaster) -> None:
    """visualization_msgs has no Python module here: the backend needs only its definition."""
    with pytest.raises(ImportError):
        __import__("visualization_msgs.msg")
    # MenuEntry: uint32 id, uint32 parent_id, string title, string command, uint8 command_type
    payload = struct.pack("<II", 7, 3) + ros_string("Open") + ros_string("open_cmd") + b"\x02"
    received: list[bytes] = []

    async def scenario(backend: Ros1Backend) -> str:
        backend.subscribe("/sb/menu", "visualization_msgs/MenuEntry", received.append)
        publisher = backend.advertise(
            "/sb/menu", "visualization_msgs/MenuEntry", queue_size=0, latch=False
        )
        while not received:
            publisher.publish(payload)
            await asyncio.sleep(0.05)
        info = await asyncio.to_thread(master.run, ["rostopic", "type", "/sb/menu"])
        return info.stdout.strip()

    assert with_backend(scenario) == "visualization_msgs/MenuEntry"
    assert received[0] == payload


def test_topics_lists_graph_with_types(master: RosMaster) -> None:
    async def scenario(backend: Ros1Backend) -> list[TopicInfo]:
        backend.advertise("/sb/listed", "sensor_msgs/Image", queue_size=1, latch=False)
        return backend.topics()

    listed = with_backend(scenario)
    assert TopicInfo("/sb/listed", "sensor_msgs/Image") in listed
    assert TopicInfo("/rosout", "rosgraph_msgs/Log") in listed
    assert listed == sorted(listed, key=lambda t: t.name)


def test_close_unregisters_from_master(master: RosMaster) -> None:
    def registered(topic: str) -> bool:
        publishers, subscribers, _ = rosgraph.Master("/sb_test").getSystemState()
        nodes = [n for t, ns in publishers + subscribers if t == topic for n in ns]
        return "/simbridge_endpoint" in nodes

    async def scenario(backend: Ros1Backend) -> None:
        publisher = backend.advertise("/sb/gone", "std_msgs/String", queue_size=1, latch=False)
        backend.subscribe("/sb/gone_too", "std_msgs/String", lambda _: None)
        assert registered("/sb/gone")
        assert registered("/sb/gone_too")
        publisher.close()
        assert not registered("/sb/gone")
        with pytest.raises(EndpointError, match="closed"):
            publisher.publish(STRING_HELLO)

    with_backend(scenario)
    assert not registered("/sb/gone_too")  # closed with the backend


def test_unknown_type_names_close_matches(master: RosMaster) -> None:
    async def scenario(backend: Ros1Backend) -> None:
        with pytest.raises(UnknownMessageTypeError, match="std_msgs/String"):
            backend.advertise("/sb/bad", "std_msgs/Strin", queue_size=1, latch=False)

    with_backend(scenario)


def test_endpoint_logs_reach_rosout(master: RosMaster) -> None:
    seen: list[bytes] = []

    async def scenario(backend: Ros1Backend) -> None:
        backend.subscribe("/rosout", "rosgraph_msgs/Log", seen.append)
        logger = logging.getLogger("simbridge.endpoint.test")
        logger.setLevel(logging.INFO)
        while not any(b"client 42 connected" in m for m in seen):
            logger.warning("client 42 connected")
            await asyncio.sleep(0.1)

    with_backend(scenario)


def test_drop_in_params_are_read_from_the_parameter_server(master: RosMaster) -> None:
    async def scenario(backend: Ros1Backend) -> tuple[str | None, int | None]:
        rosgraph.Master("/sb_test").setParam("/simbridge_endpoint/tcp_ip", "127.0.0.1")
        rosgraph.Master("/sb_test").setParam("/simbridge_endpoint/tcp_port", 10123)
        try:
            return read_drop_in_params()
        finally:
            rosgraph.Master("/sb_test").deleteParam("/simbridge_endpoint/tcp_ip")
            rosgraph.Master("/sb_test").deleteParam("/simbridge_endpoint/tcp_port")

    assert with_backend(scenario) == ("127.0.0.1", 10123)


def test_ros_args_picks_remappings_and_private_params() -> None:
    argv = ["simbridge", "endpoint", "__name:=bridge", "--port", "1", "_tcp_port:=9"]
    assert ros_args(argv) == ("__name:=bridge", "_tcp_port:=9")


def test_second_node_identity_in_one_process_is_refused(master: RosMaster) -> None:
    with pytest.raises(EndpointError, match="one node per process"):
        with_backend(lambda b: asyncio.sleep(0), Ros1Options(node_name="another_name"))


def test_missing_master_fails_fast(master: RosMaster) -> None:
    from simbridge.endpoint.backends.ros1.node import _wait_for_master

    start = time.monotonic()
    with pytest.raises(EndpointError, match="no ROS master"):
        _wait_for_master("http://127.0.0.1:1/", 2.0)
    assert time.monotonic() - start < 60  # gives up after its 2 s: it does not hang


def test_rosservice_call_reaches_sim_service(master: RosMaster) -> None:
    requests: list[bytes] = []

    async def toggle(request: bytes) -> bytes:
        requests.append(request)
        await asyncio.sleep(0)  # a real coroutine on the endpoint loop
        return b"\x01" + ros_string("on")  # SetBoolResponse(success=True, message="on")

    async def scenario(backend: Ros1Backend) -> str:
        backend.advertise_service("/sb/toggle", "std_srvs/SetBool", toggle)
        call = ["rosservice", "call", "/sb/toggle", "data: true"]
        result = await asyncio.to_thread(master.run, call)
        assert result.returncode == 0, result.stderr
        return result.stdout

    assert with_backend(scenario).split() == ["success:", "True", "message:", '"on"']
    assert requests == [b"\x01"]


def test_failing_sim_service_gives_ros_caller_an_error(master: RosMaster) -> None:
    async def broken(request: bytes) -> bytes:
        raise ValueError("motor jammed")

    async def scenario(backend: Ros1Backend) -> tuple[int, str]:
        backend.advertise_service("/sb/broken", "std_srvs/Trigger", broken)
        result = await asyncio.to_thread(master.run, ["rosservice", "call", "/sb/broken"])
        return result.returncode, result.stderr + result.stdout

    code, output = with_backend(scenario)
    assert code != 0
    assert "motor jammed" in output


def test_rospy_service_is_called_with_raw_bytes(master: RosMaster, tmp_path: Path) -> None:
    script = tmp_path / "negate_node.py"
    script.write_text(
        textwrap.dedent(
            """
            import rospy
            from std_srvs.srv import SetBool, SetBoolResponse

            def handle(req):
                return SetBoolResponse(success=not req.data, message="got %s" % req.data)

            rospy.init_node("sb_negate_server")
            rospy.Service("/sb/negate", SetBool, handle)
            rospy.spin()
            """
        )
    )

    async def scenario(backend: Ros1Backend) -> bytes:
        with master.running([SYSTEM_PYTHON, str(script)]) as node:
            await until(
                lambda: node.poll() is not None or service_registered("/sb/negate"),
                30,
                "the rospy service node",
            )
            assert node.poll() is None, node.communicate()[1]
            return await backend.call_service("/sb/negate", "std_srvs/SetBool", b"\x00", timeout=10)

    assert with_backend(scenario) == b"\x01" + ros_string("got False")


def test_missing_service_fails_fast(master: RosMaster) -> None:
    async def scenario(backend: Ros1Backend) -> float:
        start = time.monotonic()
        with pytest.raises(ServiceError, match="/sb/nobody"):
            await backend.call_service("/sb/nobody", "std_srvs/Trigger", b"", timeout=10)
        return time.monotonic() - start

    assert with_backend(scenario) < 2


def test_slow_service_times_out(master: RosMaster) -> None:
    async def slow(request: bytes) -> bytes:
        await asyncio.sleep(30)
        return b""

    async def scenario(backend: Ros1Backend) -> float:
        backend.advertise_service("/sb/slow", "std_srvs/Trigger", slow)
        start = time.monotonic()
        with pytest.raises(ServiceError, match=r"did not answer within 0\.5 s"):
            await backend.call_service("/sb/slow", "std_srvs/Trigger", b"", timeout=0.5)
        return time.monotonic() - start

    assert 0.5 <= with_backend(scenario) < 2


def test_unknown_service_type_is_a_service_error(master: RosMaster) -> None:
    async def scenario(backend: Ros1Backend) -> None:
        with pytest.raises(ServiceError, match="std_srvs/SetBool"):
            await backend.call_service("/sb/x", "std_srvs/SetBol", b"", timeout=1)

    with_backend(scenario)


def service_registered(name: str) -> bool:
    try:
        rosgraph.Master("/sb_test").lookupService(name)
    except rosgraph.MasterError:
        return False
    return True


def test_start_twice_is_one_start(master: RosMaster) -> None:
    async def scenario(backend: Ros1Backend) -> int:
        forwarders = len(logging.getLogger("simbridge").handlers)
        await backend.start()
        return len(logging.getLogger("simbridge").handlers) - forwarders

    assert with_backend(scenario) == 0


def test_ros_args_rename_node_and_set_drop_in_params(master: RosMaster, tmp_path: Path) -> None:
    """roslaunch-style `__name:=`, `__master:=` and `_tcp_port:=` args (a fresh process)."""
    script = tmp_path / "drop_in.py"
    script.write_text(
        textwrap.dedent(
            """
            import asyncio, os, rospy
            from simbridge.endpoint.backends.ros1 import Ros1Backend, Ros1Options, Ros1Publisher
            from simbridge.endpoint.backends.ros1 import read_drop_in_params

            async def main():
                uri = os.environ.pop("ROS_MASTER_URI")  # given as __master:= instead
                args = ("__name:=bridge_7", "__master:=" + uri)
                args += ("_tcp_ip:=0.0.0.0", "_tcp_port:=10555")
                backend = Ros1Backend(Ros1Options(ros_args=args))
                await backend.start()
                print(rospy.get_name(), *read_drop_in_params())
                await backend.close()

            asyncio.run(main())
            """
        )
    )
    result = master.run([sys.executable, str(script)], timeout=60)
    assert result.returncode == 0, result.stderr
    assert result.stdout.split() == ["/bridge_7", "0.0.0.0", "10555"]


def test_drop_in_params_reject_bad_values(master: RosMaster) -> None:
    async def scenario(backend: Ros1Backend) -> None:
        rosgraph.Master("/sb_test").setParam("/simbridge_endpoint/tcp_port", "ten")
        try:
            with pytest.raises(EndpointError, match=r"~tcp_port must be an integer.*'ten'"):
                read_drop_in_params()
        finally:
            rosgraph.Master("/sb_test").deleteParam("/simbridge_endpoint/tcp_port")

    with_backend(scenario)


def uint8_multi_array(data: bytes) -> bytes:
    """std_msgs/UInt8MultiArray by hand: no dims, data_offset 0, then uint8[] data."""
    return struct.pack("<II", 0, 0) + struct.pack("<I", len(data)) + data


@settings(
    max_examples=15,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(st.lists(st.binary(max_size=3000), min_size=1, max_size=12))
def test_payloads_cross_rospy_unchanged_and_in_order(
    master: RosMaster, chunks: list[bytes]
) -> None:
    payloads = [uint8_multi_array(chunk) for chunk in chunks]
    received: list[bytes] = []

    async def scenario(backend: Ros1Backend) -> None:
        backend.subscribe("/sb/prop", "std_msgs/UInt8MultiArray", received.append)
        publisher = backend.advertise(
            "/sb/prop", "std_msgs/UInt8MultiArray", queue_size=0, latch=False
        )
        assert isinstance(publisher, Ros1Publisher)
        await until(lambda: publisher.subscriber_count() > 0, 10, "the loopback connection")
        for payload in payloads:
            publisher.publish(payload)
        await until(lambda: len(received) >= len(payloads), 10, "every payload")

    with_backend(scenario)
    assert received == payloads


def test_one_type_per_topic(master: RosMaster) -> None:
    async def scenario(backend: Ros1Backend) -> None:
        backend.advertise("/sb/typed", "std_msgs/String", queue_size=1, latch=False)
        backend.subscribe("/sb/typed", "std_msgs/String", lambda _: None)  # same type: fine
        with pytest.raises(EndpointError, match="already used as std_msgs/String"):
            backend.advertise("/sb/typed", "std_msgs/Bool", queue_size=1, latch=False)
        with pytest.raises(EndpointError, match="cannot also be std_msgs/Bool"):
            backend.subscribe("sb/typed", "std_msgs/Bool", lambda _: None)  # relative name

    with_backend(scenario)


@pytest.mark.parametrize("transport", ["native", "rospy"])
def test_watch_subscribers_follows_rostopic_echo(
    master: RosMaster, transport: Literal["native", "rospy"]
) -> None:
    counts: list[int] = []

    async def scenario(backend: Ros1Backend) -> None:
        publisher = backend.advertise("/sb/watched", "std_msgs/String", queue_size=1, latch=False)
        assert publisher.watch_subscribers(counts.append)
        assert counts == [0]
        with master.running(["rostopic", "echo", "/sb/watched"]):
            await until(lambda: counts[-1] == 1, 30, "the echo to connect")
        while counts[-1] != 0:  # TCPROS notices a gone subscriber when it next writes
            publisher.publish(STRING_HELLO)
            await asyncio.sleep(0.1)

    with_backend(scenario, Ros1Options(transport=transport))
    assert counts == [0, 1, 0]


def test_custom_package_from_registry_needs_no_catkin(master: RosMaster) -> None:
    """A type known only from .msg text (like --msg-path) is advertised with genmsg's md5."""
    from simbridge.messages import MessageRegistry

    registry = MessageRegistry()
    registry.add_message("sb_custom/Reading", "float64 value\nstring sensor\n")
    payload = struct.pack("<d", 21.5) + ros_string("probe-1")
    received: list[bytes] = []

    async def main() -> tuple[str, str]:
        backend = Ros1Backend(registry=registry)
        await backend.start()
        try:
            backend.subscribe("/sb/reading", "sb_custom/Reading", received.append)
            publisher = backend.advertise(
                "/sb/reading", "sb_custom/Reading", queue_size=0, latch=False
            )
            while not received:
                publisher.publish(payload)
                await asyncio.sleep(0.05)
            info = await asyncio.to_thread(master.run, ["rostopic", "info", "/sb/reading"])
            return info.stdout, registry.md5("sb_custom/Reading")
        finally:
            await backend.close()

    info, md5 = asyncio.run(main())
    assert received[0] == payload
    assert "Type: sb_custom/Reading" in info
    # genmsg md5 of "float64 value\nstring sensor", computed independently here
    assert md5 == hashlib.md5(b"float64 value\nstring sensor").hexdigest()


def test_illegal_names_are_endpoint_errors(master: RosMaster) -> None:
    async def handler(request: bytes) -> bytes:
        return request

    async def scenario(backend: Ros1Backend) -> None:
        with pytest.raises(EndpointError, match="bad topic"):
            backend.advertise("bad topic", "std_msgs/String", queue_size=1, latch=False)
        with pytest.raises(EndpointError, match="bad topic"):
            backend.subscribe("bad topic", "std_msgs/String", lambda _: None)
        with pytest.raises(EndpointError, match="bad service"):
            backend.advertise_service("bad service", "std_srvs/Trigger", handler)

    with_backend(scenario)


def test_illegal_service_name_is_a_service_error(master: RosMaster) -> None:
    async def scenario(backend: Ros1Backend) -> None:
        with pytest.raises(ServiceError, match="not a legal ROS name"):
            await backend.call_service("bad service", "std_srvs/Trigger", b"", timeout=1)

    with_backend(scenario)
