"""Throughput of the ROS 1 backend in both directions against the rospy ceiling.

One private roscore per run. Ceiling: a rospy publisher node -> a rospy
subscriber node (both Debian's rospy with the real message classes). Through
the backend: Ros1Backend.publish -> the same rospy subscriber node (sim->ros),
and the same rospy publisher node -> Ros1Backend.subscribe callback on the
event loop (ros->sim). Publishers queue without limit, so loss must be zero.
Payloads: geometry_msgs/Twist (48 B) and a 640x480 rgb8 sensor_msgs/Image.
For reference it also measures the whole path a simulation sees: a Connector in
this process -> `simbridge endpoint --backend ros1` (a subprocess) -> the rospy
subscriber node, and back; for the image also with `--no-splice` (copied through the
endpoint rather than spliced between the sockets).

Round trip: a small message (std_msgs/Header) sent one at a time through a rospy echo
node and back, sim -> endpoint -> echo -> endpoint -> sim, beside rospy -> echo ->
rospy (a rospy pinger node in place of the sim and endpoint) in the same run; p50 and
p99 of `RT_COUNT` pings after a warm-up (target: the endpoint adds at most 50% to the
rospy p50 and 100% to its p99). The endpoint is measured twice, as started by default (its
adaptive busy poll on) and with `--busy-poll-us 0`, each with its CPU time per ping (the
price of the spin).

Every figure is taken `REPEATS` (>= 3) times in interleaved rounds; rows give the best
and the median round and the 1-minute load average when the row's first round started.
`python -m benchmarks.bench_ros1 --round-trip` runs the round trips alone, and
`--only NAME` (a MEASURES name such as full_ros_to_sim) one throughput row beside the
ceiling, without the round trips (`SIMBRIDGE_BENCH_SCALE` and `SIMBRIDGE_BENCH_REPEATS`
make it shorter).
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import os
import re
import shutil
import signal
import socket
import statistics
import struct
import subprocess
import sys
import tempfile
import textwrap
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # also as a bare script

from benchmarks.cpu import process_cpu_ns
from benchmarks.repeats import REPEATS, best_and_median, ceiling_summary, load_average
from simbridge.protocol.framing import FrameDecoder

__all__ = ["run"]

SYSTEM_PYTHON = "/usr/bin/python3"
IDLE_END = 1.5
"""Seconds without a message after which a receiver stops counting."""


@dataclass(frozen=True, slots=True)
class Payload:
    """One benchmark payload: its type, serialized bytes and how many to send."""

    label: str
    msg_type: str
    data: bytes
    count: int


def _ros_string(text: str) -> bytes:
    raw = text.encode()
    return struct.pack("<I", len(raw)) + raw


def _image(width: int, height: int) -> bytes:
    """sensor_msgs/Image rgb8: Header(seq, stamp, frame_id), height, width, encoding,
    is_bigendian, step, data."""
    header = struct.pack("<III", 0, 0, 0) + _ros_string("camera")
    pixels = bytes(range(256)) * (width * height * 3 // 256)
    body = struct.pack("<II", height, width) + _ros_string("rgb8") + b"\x00"
    body += struct.pack("<I", width * 3) + struct.pack("<I", len(pixels)) + pixels
    return header + body


SCALE = float(os.environ.get("SIMBRIDGE_BENCH_SCALE", "1"))
"""Multiplies the message counts (smaller for a quick look)."""

PAYLOADS = (
    Payload(
        "Twist 48 B",
        "geometry_msgs/Twist",
        struct.pack("<6d", 1, 2, 3, 4, 5, 6),
        max(int(20000 * SCALE), 10),
    ),
    # 500 images: about 0.5 s at the ceiling's rate (with 300, a single scheduling hiccup
    # on a shared 2-core machine moved a row by tens of percent), and below the 512 MiB a
    # ROS 1 subscriber connection holds when Ros1Backend.publish is given them all at once.
    Payload("Image 640x480 rgb8", "sensor_msgs/Image", _image(640, 480), max(int(500 * SCALE), 5)),
)

_NODE_SCRIPT = textwrap.dedent(
    """
    import json, sys, time
    import rospy
    from geometry_msgs.msg import Twist
    from sensor_msgs.msg import Image

    role, topic, msg_type, count = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4])
    cls = Twist if msg_type == "geometry_msgs/Twist" else Image
    rospy.init_node("bench_" + role, anonymous=True)
    if role == "pub":
        if msg_type == "geometry_msgs/Twist":
            msg = Twist()
            msg.linear.x, msg.linear.y, msg.linear.z = 1, 2, 3
            msg.angular.x, msg.angular.y, msg.angular.z = 4, 5, 6
        else:
            pixels = bytes(range(256)) * (640 * 480 * 3 // 256)
            msg = Image(height=480, width=640, encoding="rgb8", step=1920, data=pixels)
            msg.header.frame_id = "camera"
        pub = rospy.Publisher(topic, cls, queue_size=0)
        while pub.get_num_connections() == 0:
            time.sleep(0.01)
        print("READY", flush=True)
        sys.stdin.readline()
        for _ in range(count):
            pub.publish(msg)
        sys.stdin.readline()
    else:
        times = []
        sub = rospy.Subscriber(topic, cls, lambda m: times.append(time.perf_counter()))
        deadline = time.time() + 30
        while sub.get_num_connections() == 0 and time.time() < deadline:
            time.sleep(0.01)
        print("READY", flush=True)
        deadline = time.time() + 60
        while not times and time.time() < deadline:
            time.sleep(0.01)
        while len(times) < count:
            before = len(times)
            time.sleep(%(idle)s)
            if len(times) == before:
                break
        print(json.dumps({"times": [times[0], times[-1]] if times else [], "count": len(times)}))
    """
)


RT_COUNT = max(int(1000 * SCALE), 50)
"""Pings per round-trip run (after `RT_WARMUP` unmeasured ones)."""
RT_WARMUP = 50
RT_TYPE = "std_msgs/Header"
RT_PAYLOAD = struct.pack("<III", 0, 0, 0) + _ros_string("rt")
"""The ping: a std_msgs/Header (seq, stamp, frame_id "rt") in ROS 1 binary."""

_RT_SCRIPT = textwrap.dedent(
    """
    import json, sys, threading, time
    import rospy
    from std_msgs.msg import Header

    role, ping, pong = sys.argv[1], sys.argv[2], sys.argv[3]
    rospy.init_node("rt_" + role, anonymous=True)
    if role == "echo":
        out = rospy.Publisher(pong, Header, queue_size=10)
        rospy.Subscriber(ping, Header, out.publish, tcp_nodelay=True)
        print("READY", flush=True)
        sys.stdin.readline()
    else:
        count, warmup = int(sys.argv[4]), int(sys.argv[5])
        got = threading.Event()
        rospy.Subscriber(pong, Header, lambda m: got.set(), tcp_nodelay=True)
        out = rospy.Publisher(ping, Header, queue_size=10)
        msg = Header(frame_id="rt")
        deadline = time.time() + 30
        while time.time() < deadline:  # until the echo's connections both ways are up
            got.clear()
            out.publish(msg)
            if got.wait(0.2):
                break
        samples = []
        for i in range(warmup + count):
            got.clear()
            start = time.perf_counter()
            out.publish(msg)
            if got.wait(2) and i >= warmup:
                samples.append((time.perf_counter() - start) * 1e6)
        print(json.dumps(samples), flush=True)
    """
)


@contextlib.contextmanager
def _roscore() -> Iterator[dict[str, str]]:
    """A private roscore; yields the environment ROS processes need to use it."""
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
    home = Path(tempfile.mkdtemp(prefix="simbridge-bench-"))
    env = dict(os.environ, ROS_MASTER_URI=f"http://127.0.0.1:{port}/", ROS_HOSTNAME="127.0.0.1")
    env.update(ROS_HOME=str(home), ROS_LOG_DIR=str(home / "log"), PYTHONUNBUFFERED="1")
    core = subprocess.Popen(
        ["roscore", "-p", str(port)],
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
    )
    try:
        probe = subprocess.run(
            ["rostopic", "list"], env=env, capture_output=True, timeout=30, check=False
        )
        deadline = time.monotonic() + 30
        while b"/rosout" not in probe.stdout and time.monotonic() < deadline:
            time.sleep(0.2)
            probe = subprocess.run(
                ["rostopic", "list"], env=env, capture_output=True, timeout=30, check=False
            )
        yield env
    finally:
        os.killpg(core.pid, signal.SIGINT)
        try:
            core.wait(5)
        except subprocess.TimeoutExpired:
            os.killpg(core.pid, signal.SIGKILL)
            core.wait()
        shutil.rmtree(home, ignore_errors=True)


class _Node:
    """A helper rospy node (publisher or subscriber) in the system interpreter."""

    def __init__(self, env: dict[str, str], script: Path, role: str, topic: str, p: Payload):
        args = [SYSTEM_PYTHON, str(script), role, topic, p.msg_type, str(p.count)]
        self._proc = subprocess.Popen(
            args,
            env=env,
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
            start_new_session=True,
        )

    def wait_ready(self) -> None:
        assert self._proc.stdout is not None
        line = self._proc.stdout.readline()
        if line.strip() != "READY":
            raise RuntimeError(f"bench node failed to start: {line!r}")

    def send(self) -> None:
        assert self._proc.stdin is not None
        self._proc.stdin.write("\n")
        self._proc.stdin.flush()

    def result(self) -> dict[str, Any]:
        assert self._proc.stdout is not None
        line = self._proc.stdout.readline()
        data: dict[str, Any] = json.loads(line)
        return data

    def stop(self) -> None:
        if self._proc.poll() is None:
            with contextlib.suppress(BrokenPipeError, OSError):
                self.send()
            try:
                self._proc.wait(5)
            except subprocess.TimeoutExpired:
                os.killpg(self._proc.pid, signal.SIGKILL)
                self._proc.wait()


def _row(direction: str, p: Payload, received: int, span: float) -> dict[str, Any]:
    rate = (received - 1) / span if received > 1 and span > 0 else 0.0
    return {
        "direction": direction,
        "payload": p.label,
        "sent": p.count,
        "received": received,
        "msg_per_s": rate,
        "mb_per_s": rate * len(p.data) / 1e6,
        "loss": 1 - received / p.count,
    }


def _ceiling(env: dict[str, str], script: Path, p: Payload, topic: str) -> dict[str, Any]:
    sub = _Node(env, script, "sub", topic, p)
    pub = _Node(env, script, "pub", topic, p)
    try:
        pub.wait_ready()
        sub.wait_ready()
        pub.send()
        result = sub.result()
    finally:
        pub.stop()
        sub.stop()
    span = result["times"][1] - result["times"][0] if result["times"] else 0.0
    return _row("rospy -> rospy (ceiling)", p, result["count"], span)


async def _sim_to_ros(env: dict[str, str], script: Path, p: Payload, topic: str) -> dict[str, Any]:
    from simbridge.endpoint.backends.ros1 import Ros1Backend, Ros1Publisher

    backend = Ros1Backend()
    await backend.start()
    sub = _Node(env, script, "sub", topic, p)
    try:
        publisher = backend.advertise(topic, p.msg_type, queue_size=0, latch=False)
        assert isinstance(publisher, Ros1Publisher)
        await asyncio.to_thread(sub.wait_ready)
        while publisher.subscriber_count() == 0:
            await asyncio.sleep(0.01)
        for _ in range(p.count):
            publisher.publish(p.data)
        result = await asyncio.to_thread(sub.result)
        publisher.close()
    finally:
        sub.stop()
        await backend.close()
    span = result["times"][1] - result["times"][0] if result["times"] else 0.0
    return _row("sim -> ros (Ros1Backend.publish)", p, result["count"], span)


async def _ros_to_sim(env: dict[str, str], script: Path, p: Payload, topic: str) -> dict[str, Any]:
    from simbridge.endpoint.backends.ros1 import Ros1Backend

    backend = Ros1Backend()
    await backend.start()
    times: list[float] = []
    sizes: set[int] = set()

    def on_message(payload: bytes) -> None:
        times.append(time.perf_counter())
        sizes.add(len(payload))

    subscription = backend.subscribe(topic, p.msg_type, on_message)
    pub = _Node(env, script, "pub", topic, p)
    try:
        await asyncio.to_thread(pub.wait_ready)
        pub.send()
        while len(times) < p.count:
            before = len(times)
            await asyncio.sleep(IDLE_END)
            if len(times) == before:
                break
    finally:
        pub.stop()
        subscription.close()
        await backend.close()
    if sizes and sizes != {len(p.data)}:
        raise RuntimeError(f"payload sizes {sizes} differ from the {len(p.data)} sent")
    span = times[-1] - times[0] if times else 0.0
    return _row("ros -> sim (Ros1Backend.subscribe)", p, len(times), span)


class _EndpointProcess:
    """`simbridge endpoint --backend ros1` as its own process and ROS node."""

    def __init__(self, env: dict[str, str], *extra: str) -> None:
        command = [sys.executable, "-m", "simbridge.cli", "--log-level", "WARNING", "endpoint"]
        command += ["--backend", "ros1", "--node-name", "/bench_endpoint", "--port", "0"]
        self._proc = subprocess.Popen(
            [*command, "--idle-timeout", "0", *extra],
            env=env,
            stdout=subprocess.PIPE,
            text=True,
            start_new_session=True,
        )
        assert self._proc.stdout is not None
        line = self._proc.stdout.readline()
        found = re.search(r"listening on \S+:(\d+)", line)
        if found is None:
            self.stop()
            raise RuntimeError(f"the endpoint did not start: {line!r}")
        self.port = int(found[1])

    def cpu_seconds(self) -> float:
        """CPU time its threads have run so far (user and system)."""
        return process_cpu_ns(self._proc.pid) / 1e9

    def stop(self) -> None:
        if self._proc.poll() is None:
            os.killpg(self._proc.pid, signal.SIGINT)
            try:
                self._proc.wait(10)
            except subprocess.TimeoutExpired:
                os.killpg(self._proc.pid, signal.SIGKILL)
                self._proc.wait()


def _connector(port: int, p: Payload) -> Any:
    from simbridge.connector import Connector, ConnectorOptions

    options = ConnectorOptions(publish_queue_size=p.count + 10, subscribe_queue_size=p.count + 10)
    return Connector("127.0.0.1", port, options).connect(wait=10)


def _full_sim_to_ros(
    env: dict[str, str], script: Path, p: Payload, topic: str, *endpoint_args: str
) -> dict[str, Any]:
    endpoint = _EndpointProcess(env, *endpoint_args)
    conn = _connector(endpoint.port, p)
    sub = _Node(env, script, "sub", topic, p)
    try:
        publisher = conn.register_publisher(
            topic, p.msg_type, queue_size=0, report_subscribers=True
        )
        sub.wait_ready()
        # the subscriber saw the connection; wait until the endpoint's side counts it too
        deadline = time.monotonic() + 10
        while not publisher.subscriber_count and time.monotonic() < deadline:
            time.sleep(0.01)
        for _ in range(p.count):
            publisher.publish(p.data)
        result = sub.result()
    finally:
        sub.stop()
        conn.close()
        endpoint.stop()
    span = result["times"][1] - result["times"][0] if result["times"] else 0.0
    label = "sim -> ros (connector -> endpoint)"
    return _row(f"the same, endpoint {' '.join(endpoint_args)}" if endpoint_args else label,
                p, result["count"], span)  # fmt: skip


def _full_ros_to_sim(env: dict[str, str], script: Path, p: Payload, topic: str) -> dict[str, Any]:
    endpoint = _EndpointProcess(env)
    conn = _connector(endpoint.port, p)
    times: list[float] = []
    pub = _Node(env, script, "pub", topic, p)
    try:
        conn.subscribe(topic, p.msg_type, lambda _: times.append(time.perf_counter()), raw=True)
        pub.wait_ready()
        pub.send()
        while len(times) < p.count:
            before = len(times)
            time.sleep(IDLE_END)
            if len(times) == before:
                break
    finally:
        pub.stop()
        conn.close()
        endpoint.stop()
    span = times[-1] - times[0] if times else 0.0
    return _row("ros -> sim (endpoint -> connector)", p, len(times), span)


def _start_rt(env: dict[str, str], script: Path, *args: str) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [SYSTEM_PYTHON, str(script), *args],
        env=env,
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )


def _stop(proc: subprocess.Popen[str]) -> None:
    """End a node: a line on its stdin asks it to exit; killed (as a group) if it does not."""
    if proc.poll() is None:
        with contextlib.suppress(BrokenPipeError, OSError):
            assert proc.stdin is not None
            proc.stdin.write("\n")
            proc.stdin.flush()
        try:
            proc.wait(5)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()


def _echo(env: dict[str, str], script: Path, ping: str, pong: str) -> subprocess.Popen[str]:
    """The rospy echo node: every message on `ping` goes back out on `pong`."""
    echo = _start_rt(env, script, "echo", ping, pong)
    assert echo.stdout is not None
    line = echo.stdout.readline()
    if line.strip() != "READY":
        _stop(echo)
        raise RuntimeError(f"the echo node failed to start: {line!r}")
    return echo


def _latency(samples: list[float]) -> dict[str, float]:
    if not samples:
        raise RuntimeError("no ping came back")
    ordered = sorted(samples)
    return {
        "p50_us": statistics.median(ordered),
        "p99_us": ordered[max(int(len(ordered) * 0.99) - 1, 0)],
        "lost": RT_COUNT - len(ordered),
    }


def _rospy_round_trip(env: dict[str, str], script: Path, topic: str) -> dict[str, float]:
    """rospy pinger -> rospy echo -> rospy pinger."""
    echo = _echo(env, script, topic + "/ping", topic + "/pong")
    try:
        args = ["ping", topic + "/ping", topic + "/pong", str(RT_COUNT), str(RT_WARMUP)]
        pinger = _start_rt(env, script, *args)
        try:
            out, _ = pinger.communicate(timeout=120)
        finally:
            _stop(pinger)
    finally:
        _stop(echo)
    return _latency(json.loads(out.strip().splitlines()[-1]))


def _endpoint_round_trip(
    env: dict[str, str], script: Path, topic: str, *endpoint_args: str
) -> dict[str, float]:
    """Connector -> `simbridge endpoint --backend ros1 [endpoint_args]` -> rospy echo ->
    endpoint -> Connector; with the endpoint's CPU time per ping."""
    from simbridge.connector import Connector

    endpoint = _EndpointProcess(env, *endpoint_args)
    conn = Connector("127.0.0.1", endpoint.port).connect(wait=10)
    echo: subprocess.Popen[str] | None = None
    try:
        got = threading.Event()
        conn.subscribe(topic + "/pong", RT_TYPE, lambda _: got.set(), raw=True)
        ping = conn.register_publisher(topic + "/ping", RT_TYPE, queue_size=10)
        echo = _echo(env, script, topic + "/ping", topic + "/pong")
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline:  # until the echo's connections both ways are up
            got.clear()
            ping.publish(RT_PAYLOAD)
            if got.wait(0.2):
                break
        samples = []
        for i in range(RT_WARMUP + RT_COUNT):
            if i == RT_WARMUP:
                cpu = endpoint.cpu_seconds()
            got.clear()
            start = time.perf_counter()
            ping.publish(RT_PAYLOAD)
            if got.wait(2) and i >= RT_WARMUP:
                samples.append((time.perf_counter() - start) * 1e6)
        cpu = endpoint.cpu_seconds() - cpu
    finally:
        if echo is not None:
            _stop(echo)
        conn.close()
        endpoint.stop()
    return {**_latency(samples), "endpoint_cpu_us": cpu / RT_COUNT * 1e6}


Measure = Callable[[dict[str, str], Path, Payload, str], dict[str, Any]]
MEASURES: list[tuple[str, Measure]] = [
    ("ceiling", _ceiling),  # first: the other rows are shares of it
    ("sim_to_ros", lambda env, script, p, t: asyncio.run(_sim_to_ros(env, script, p, t))),
    ("ros_to_sim", lambda env, script, p, t: asyncio.run(_ros_to_sim(env, script, p, t))),
    ("full_sim_to_ros", _full_sim_to_ros),
    ("full_sim_to_ros_copy", lambda env, s, p, t: _full_sim_to_ros(env, s, p, t, "--no-splice")),
    ("full_ros_to_sim", _full_ros_to_sim),
]
"""Throughput measurements of one round, each on its own topic."""

_LARGE_ONLY = {"full_sim_to_ros_copy"}
"""Rows measured only for payloads the endpoint treats as large (spliced by default)."""

THROUGHPUT_TITLE = (
    "ROS 1 backend against the rospy ceiling, same run "
    "(targets: >= 100% sim->ROS, >= 95% ROS->sim, zero loss)"
)
ROUND_TRIP_TITLE = (
    "ROS 1 round trip through a rospy echo node, beside rospy -> echo -> rospy in the same "
    "run (target: the endpoint adds <= 50% to the rospy p50, <= 100% to its p99)"
)


def run(
    repeats: int = REPEATS, round_trip_only: bool = False, only: str | None = None
) -> dict[str, list[dict[str, Any]]]:
    """Every direction and payload, then the round trips, in `repeats` interleaved rounds
    (the machine may be shared); rows give the best and the median round. With
    `round_trip_only` just the round trips (`--round-trip` on the command line); with
    `only` (a MEASURES name) that throughput row beside the ceiling (`--only NAME`)."""
    measures = MEASURES
    if only is not None:
        measures = [m for m in MEASURES if m[0] in ("ceiling", only)]
        if len(measures) < 2:
            raise ValueError(f"--only {only!r}: not one of {', '.join(n for n, _ in MEASURES)}")
    with _roscore() as env, tempfile.TemporaryDirectory() as tmp:
        os.environ.update({k: v for k, v in env.items() if k.startswith("ROS_")})
        script = Path(tmp, "bench_node.py")
        script.write_text(_NODE_SCRIPT % {"idle": IDLE_END})
        rt_script = Path(tmp, "rt_node.py")
        rt_script.write_text(_RT_SCRIPT)
        tables: dict[str, list[dict[str, Any]]] = {}
        if not round_trip_only:
            tables[THROUGHPUT_TITLE] = _throughput(env, script, repeats, measures)
        if only is None:
            tables[ROUND_TRIP_TITLE] = _round_trips(env, rt_script, repeats)
    return tables


def _throughput(
    env: dict[str, str], script: Path, repeats: int, measures: list[tuple[str, Measure]]
) -> list[dict[str, Any]]:
    """Every row of `measures` (the ceiling first) for every payload, in `repeats` rounds."""
    throughput: list[dict[str, Any]] = []
    every = measures
    for i, p in enumerate(PAYLOADS):
        large = len(p.data) >= FrameDecoder.LARGE
        measures = [m for m in every if large or m[0] not in _LARGE_ONLY]
        loads: list[float] = []
        rounds: list[list[dict[str, Any]]] = []
        for r in range(repeats):
            results = []
            for name, measure in measures:
                if r == 0:
                    loads.append(load_average())
                results.append(measure(env, script, p, f"/bench/p{i}r{r}/{name}"))
            rounds.append(results)
        size = len(p.data)
        throughput.extend(ceiling_summary(rounds, k, loads[k], size) for k in range(len(measures)))
    return throughput


def _round_trips(env: dict[str, str], rt_script: Path, repeats: int) -> list[dict[str, Any]]:
    """rospy and endpoint round trips in `repeats` alternating rounds; each ratio is
    against the rospy round trip of the same round."""
    rt: dict[str, list[dict[str, float]]] = {"rospy": [], "endpoint": [], "off": []}
    rt_loads: dict[str, float] = {}
    for r in range(repeats):
        rt_loads.setdefault("rospy", load_average())
        rt["rospy"].append(_rospy_round_trip(env, rt_script, f"/bench/rt{r}/rospy"))
        rt_loads.setdefault("endpoint", load_average())
        rt["endpoint"].append(_endpoint_round_trip(env, rt_script, f"/bench/rt{r}/endpoint"))
        rt_loads.setdefault("off", load_average())
        topic = f"/bench/rt{r}/off"
        rt["off"].append(_endpoint_round_trip(env, rt_script, topic, "--busy-poll-us", "0"))
    labels = {
        "rospy": "rospy -> rospy echo -> rospy",
        "endpoint": "sim -> endpoint -> rospy echo -> endpoint -> sim",
        "off": "the same, endpoint --busy-poll-us 0 (spin off)",
    }
    round_trips: list[dict[str, Any]] = []
    for key, runs in rt.items():
        row: dict[str, Any] = {"path": labels[key], "pings": RT_COUNT, "load_1min": rt_loads[key]}
        for figure in ("p50_us", "p99_us"):
            values = [run[figure] for run in runs]
            row[f"{figure}_best"], row[f"{figure}_median"] = best_and_median(values, True)
            # The share of the rospy figure, round by round (1.5 = 50% added).
            ratios = [a[figure] / b[figure] for a, b in zip(runs, rt["rospy"], strict=True)]
            row[f"{figure}_vs_rospy"] = statistics.median(ratios)
        cpu = [run["endpoint_cpu_us"] for run in runs if "endpoint_cpu_us" in run]
        row["endpoint_cpu_us_per_ping"] = statistics.median(cpu) if cpu else ""
        row["lost"] = sum(int(run["lost"]) for run in runs)
        round_trips.append(row)
    return round_trips


if __name__ == "__main__":
    from benchmarks.table import format_table
    from benchmarks.usage import exit_on_help

    exit_on_help(
        __doc__,
        "  --round-trip  the round trips alone\n"
        "  --only NAME   one throughput row (a MEASURES name) beside the ceiling\n"
        "  --markdown    Markdown tables",
    )
    only = sys.argv[sys.argv.index("--only") + 1] if "--only" in sys.argv[:-1] else None
    for title, table in run(round_trip_only="--round-trip" in sys.argv, only=only).items():
        print(f"### {title}\n\n{format_table(table, markdown='--markdown' in sys.argv)}\n")
