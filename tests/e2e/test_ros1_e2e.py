"""End to end: connector -> `simbridge endpoint --backend ros1` (a subprocess) -> real ROS tools.

The module has its own roscore; the endpoint runs as `python -m simbridge.cli endpoint`
so it is a separate ROS node that can be killed and restarted.
"""

from __future__ import annotations

import contextlib
import operator
import re
import struct
import subprocess
import sys
import textwrap
import time
from collections.abc import Callable, Iterator
from functools import partial
from pathlib import Path

import pytest
from tests.ros1support import (
    FAST,
    SYSTEM_PYTHON,
    EndpointProcess,
    RosMaster,
    require_ros,
    ros_string,
    terminate,
    wait_until,
)

from simbridge.connector import Connector
from simbridge.errors import ServiceError

require_ros(module_level=True)

import rosgraph  # noqa: E402

pytestmark = [pytest.mark.ros1, pytest.mark.timeout(180)]


@pytest.fixture(scope="module")
def endpoint(master: RosMaster) -> Iterator[EndpointProcess]:
    ep = EndpointProcess(master, "/simbridge_endpoint")
    yield ep
    ep.stop()


@pytest.fixture
def connector(endpoint: EndpointProcess) -> Iterator[Connector]:
    conn = Connector("127.0.0.1", endpoint.port, FAST).connect(wait=10)
    yield conn
    conn.close()


def registered(master: RosMaster, name: str, kind: int) -> bool:
    """Whether `name` has a provider in the master: kind 0 publishers, 1 subscribers, 2 services."""
    state = rosgraph.Master("/e2e_test", master_uri=master.uri).getSystemState()
    return any(entry == name for entry, _ in state[kind])


def echo_once(master: RosMaster, topic: str, publish: Callable[[], None]) -> str:
    """Run `rostopic echo -n 1 topic`, calling `publish` until it has printed a message."""
    with master.running(["rostopic", "echo", "-n", "1", topic]) as echo:
        deadline = time.monotonic() + 30
        while echo.poll() is None and time.monotonic() < deadline:
            publish()
            time.sleep(0.1)
        out, err = echo.communicate(timeout=5)
    assert echo.returncode == 0, err
    return out


def test_endpoint_keeps_its_console_logging_after_joining(endpoint: EndpointProcess) -> None:
    """rospy's logging config replaces root handlers; the CLI's console must survive it."""
    assert any("joined ROS master" in line for line in endpoint.lines)


def test_connector_publication_reaches_rostopic_echo(
    master: RosMaster, connector: Connector
) -> None:
    publisher = connector.register_publisher("/e2e/chatter", "std_msgs/String")
    out = echo_once(master, "/e2e/chatter", lambda: publisher.publish(ros_string("from sim")))
    assert out.splitlines()[0] == 'data: "from sim"'


def test_rostopic_pub_reaches_connector_subscriber(master: RosMaster, connector: Connector) -> None:
    received: list[bytes] = []
    connector.subscribe("/e2e/cmd_vel", "geometry_msgs/Twist", received.append, raw=True)
    wait_until(lambda: registered(master, "/e2e/cmd_vel", 1), 10, "the endpoint's subscription")
    twist = "{linear: {x: 0.5}, angular: {z: -1.25}}"
    with master.running(
        ["rostopic", "pub", "-r", "10", "/e2e/cmd_vel", "geometry_msgs/Twist", twist]
    ):
        wait_until(lambda: bool(received), 30, "a Twist at the connector")
    assert received[0] == struct.pack("<6d", 0.5, 0, 0, 0, 0, -1.25)


def test_rosservice_call_reaches_sim_service(master: RosMaster, connector: Connector) -> None:
    requests: list[bytes] = []

    def toggle(request: bytes) -> bytes:
        requests.append(request)
        return b"\x01" + ros_string("sim says on")

    connector.implement_service("/e2e/toggle", "std_srvs/SetBool", toggle, raw=True)
    wait_until(lambda: registered(master, "/e2e/toggle", 2), 10, "the sim service in the master")
    result = master.run(["rosservice", "call", "/e2e/toggle", "data: true"])
    assert result.returncode == 0, result.stderr
    assert result.stdout.split() == ["success:", "True", "message:", '"sim', "says", 'on"']
    assert requests == [b"\x01"]


def test_rospy_service_is_called_from_connector(
    master: RosMaster, connector: Connector, tmp_path: Path
) -> None:
    script = tmp_path / "negate_node.py"
    script.write_text(
        textwrap.dedent(
            """
            import rospy
            from std_srvs.srv import SetBool, SetBoolResponse

            def handle(req):
                return SetBoolResponse(success=not req.data, message="rospy got %s" % req.data)

            rospy.init_node("e2e_negate_server")
            rospy.Service("/e2e/negate", SetBool, handle)
            rospy.spin()
            """
        )
    )
    with master.running([SYSTEM_PYTHON, str(script)]) as node:
        wait_until(
            lambda: node.poll() is not None or registered(master, "/e2e/negate", 2),
            30,
            "rospy service",
        )
        assert node.poll() is None, node.communicate()[1]
        connector.register_ros_service("/e2e/negate", "std_srvs/SetBool")
        response = connector.call("/e2e/negate", b"\x01", timeout=10)
    assert response == b"\x00" + ros_string("rospy got True")


def test_missing_ros_service_fails_fast(connector: Connector) -> None:
    connector.register_ros_service("/e2e/nobody", "std_srvs/Trigger")
    # the endpoint's answer fails it, not the call's own timeout (600 s, past the 60 s wait)
    future = connector.call_service("/e2e/nobody", b"", 600.0)
    with pytest.raises(ServiceError):
        future.result(60.0)


def test_latched_topic_reaches_late_subscriber(master: RosMaster, connector: Connector) -> None:
    publisher = connector.register_publisher("/e2e/map_name", "std_msgs/String", latch=True)
    publisher.publish(ros_string("warehouse"))
    assert connector.flush(5)
    wait_until(lambda: registered(master, "/e2e/map_name", 0), 10, "the latched publisher")
    time.sleep(0.5)  # the endpoint hands the frame to rospy after reading it
    result = master.run(["rostopic", "echo", "-n", "1", "/e2e/map_name"])
    assert result.returncode == 0, result.stderr
    assert result.stdout.splitlines()[0] == 'data: "warehouse"'


def test_restarted_endpoint_gets_data_flowing_again(master: RosMaster) -> None:
    # Its own node name: a second node with the module endpoint's name would make the
    # master shut that one down (ROS replaces a node by a newcomer with the same name).
    name = "/simbridge_restarted"
    first = EndpointProcess(master, name)
    port = first.port
    conn = Connector("127.0.0.1", port, FAST).connect(wait=10)
    second: EndpointProcess | None = None
    try:
        publisher = conn.register_publisher("/e2e/heartbeat", "std_msgs/String")
        before = echo_once(master, "/e2e/heartbeat", lambda: publisher.publish(ros_string("one")))
        assert before.splitlines()[0] == 'data: "one"'

        first.kill()
        wait_until(lambda: not conn.connected, 10, "the connector to notice the crash")
        second = EndpointProcess(master, name, port=port)
        assert conn.wait_connected(15)

        def publish() -> None:
            with contextlib.suppress(Exception):
                publisher.publish(ros_string("two"))

        after = echo_once(master, "/e2e/heartbeat", publish)
        assert after.splitlines()[0] == 'data: "two"'
    finally:
        conn.close()
        first.stop()
        if second is not None:
            second.stop()


def test_remove_commands_and_disconnect_unregister_from_master(
    master: RosMaster, endpoint: EndpointProcess
) -> None:
    conn = Connector("127.0.0.1", endpoint.port, FAST).connect(wait=10)
    try:
        conn.register_publisher("/e2e/short_lived", "std_msgs/String")
        conn.subscribe("/e2e/listened", "std_msgs/String", lambda _: None, raw=True)
        conn.implement_service("/e2e/served", "std_srvs/Trigger", lambda _: b"", raw=True)
        wait_until(lambda: registered(master, "/e2e/short_lived", 0), 10, "the publisher")
        wait_until(lambda: registered(master, "/e2e/listened", 1), 10, "the subscriber")
        wait_until(lambda: registered(master, "/e2e/served", 2), 10, "the service")

        conn.unregister_publisher("/e2e/short_lived")  # __remove_publisher
        wait_until(lambda: not registered(master, "/e2e/short_lived", 0), 10, "unpublish")
        assert registered(master, "/e2e/listened", 1)
    finally:
        conn.close()
    wait_until(lambda: not registered(master, "/e2e/listened", 1), 10, "unsubscribe on close")
    wait_until(lambda: not registered(master, "/e2e/served", 2), 10, "unadvertise on close")


def test_topic_list_comes_from_the_master(master: RosMaster, connector: Connector) -> None:
    connector.register_publisher("/e2e/listed", "sensor_msgs/Image")
    wait_until(lambda: registered(master, "/e2e/listed", 0), 10, "the publisher")
    topics = connector.topic_list()
    assert topics["/e2e/listed"] == "sensor_msgs/Image"
    assert topics["/rosout"] == "rosgraph_msgs/Log"


def test_endpoint_events_reach_rosout(master: RosMaster, connector: Connector) -> None:
    echo = master.spawn(["rostopic", "echo", "/rosout"])
    try:
        expected = "publishing /e2e/logged [std_msgs/String] for the sim"
        deadline = time.monotonic() + 30
        while expected not in echo.output()[0]:  # until echo is connected
            assert time.monotonic() < deadline, "the endpoint's event never reached /rosout"
            connector.register_publisher("/e2e/logged", "std_msgs/String")
            time.sleep(0.5)
    finally:
        terminate(echo)


def test_drop_in_private_params_choose_the_address(master: RosMaster) -> None:
    """Like ros_tcp_endpoint under roslaunch: `_tcp_ip:=` / `_tcp_port:=` set where it listens."""
    command = [sys.executable, "-m", "simbridge.cli", "endpoint", "--backend", "ros1"]
    process = subprocess.Popen(  # port 0: the OS chooses (not the default 10000); read back
        [*command, "--node-name", "/dropin_endpoint", "_tcp_ip:=127.0.0.1", "_tcp_port:=0"],
        env=master.env,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        stdin=subprocess.DEVNULL,
        text=True,
        start_new_session=True,
    )
    try:
        assert process.stdout is not None
        line = ""
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline and "listening on" not in line:
            line = process.stdout.readline()
            if not line:
                break
        found = re.search(r"listening on 127\.0\.0\.1:(\d+)", line)
        assert found is not None, line
        port = int(found.group(1))
        assert port not in (0, 10000)  # the param was read, the default not taken
        with Connector("127.0.0.1", port, FAST).connect(wait=10) as conn:
            assert isinstance(conn.topic_list(), dict)
    finally:
        terminate(process)


def test_busy_polling_endpoint_relays_round_trips_through_a_rospy_echo(
    master: RosMaster, tmp_path: Path
) -> None:
    """The adaptive busy poll (a limit wide enough for a loaded machine): pings go out and back
    through a rospy echo node in order, and the exit line shows spins that found answers."""
    script = tmp_path / "echo_node.py"
    script.write_text(
        textwrap.dedent(
            """
            import rospy
            from std_msgs.msg import String

            rospy.init_node("e2e_busy_echo")
            out = rospy.Publisher("/e2e/busy/pong", String, queue_size=10)
            rospy.Subscriber("/e2e/busy/ping", String, out.publish, tcp_nodelay=True)
            rospy.spin()
            """
        )
    )
    endpoint = EndpointProcess(master, "/simbridge_busy", "--busy-poll-us", "20000")
    got: list[bytes] = []
    try:
        with Connector("127.0.0.1", endpoint.port, FAST).connect(wait=10) as conn:
            conn.subscribe("/e2e/busy/pong", "std_msgs/String", got.append, raw=True)
            ping = conn.register_publisher("/e2e/busy/ping", "std_msgs/String")
            with master.running([SYSTEM_PYTHON, str(script)]):
                deadline = time.monotonic() + 30
                while not got and time.monotonic() < deadline:  # until the echo is wired up
                    ping.publish(ros_string("hello"))
                    time.sleep(0.1)
                for i in range(20):
                    pong = ros_string(f"ping {i}")
                    ping.publish(pong)
                    wait_until(partial(operator.contains, got, pong), 10, f"pong {i}")
    finally:
        endpoint.stop()
    pongs = [m for m in got if m != ros_string("hello")]  # the echo's warm-up left aside
    assert pongs == [ros_string(f"ping {i}") for i in range(20)]
    wait_until(lambda: "busy poll:" in endpoint.output(), 10, "the endpoint's exit line")
    line = next(x for x in endpoint.lines if "busy poll:" in x)
    found = re.search(r"(\d+) polls, (\d+) spins found I/O", line)
    assert found is not None, line
    assert int(found[1]) > 0, line
    assert int(found[2]) > 0, line
