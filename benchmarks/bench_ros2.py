"""Throughput of the ROS 2 backend in both directions against the rclpy ceiling, and latency.

Everything rclpy runs with the ROS 2 venv's Python (.venv-ros2), in a ROS domain of
its own, localhost only (`backends.ros2.env`). Ceiling: a raw rclpy publisher process -> a raw
rclpy subscriber process (`publish(bytes)`, `raw=True`; the endpoint's executor and
burst take). Through the endpoint: a
Connector in this process -> `simbridge endpoint --backend ros2` (a subprocess) ->
the same subscriber process (sim -> ros), and the same publisher process -> the
endpoint -> the Connector (ros -> sim). Publishing starts once the subscriber process
has matched its publisher too (a sample sent before that waits for reliability's
repair). Both publish with rclpy's `publish_raw`, as the endpoint does. The endpoint's
memory budget fits the image burst, so a lagging Connector costs time, not messages.
The sim as its own ROS 2 node (`simbridge sim --ros2`): bench_ros2_sim_node.py, a ROS 2 venv
process publishing through `Ros2SimNode`'s connector -> the same subscriber process.
QoS is reliable with a history as deep as the run, so loss should be zero. A rate counts
from the first message sent to the last one received, so a path that hands its first
message over late (a batch arriving at once) does not look faster for it. Payloads:
geometry_msgs/Twist and a 640x480 rgb8 sensor_msgs/Image. Latency: Twists sent by the
Connector, echoed back by an rclpy node (raw), timed per message at a modest rate:
sim -> ROS 2 -> sim, alternating with the reference, an rclpy node that publishes the same
Twists at the same rate and waits for the same echo (its executor woken by the reply).

`--cpu` runs only the throughput rows (`--cpu twist` or `--cpu image`: one payload's), with
the CPU each process spends per message (every thread's run time from
/proc/PID/task/*/schedstat, sampled every 10 ms and interpolated at the first send and the
last receipt; this process, the Connector, without its sampling thread), and the rate those
figures allow: processes sharing N cores relay at most N / (sum of their CPU per message)
messages per second.
"""

from __future__ import annotations

import itertools
import json
import os
import queue
import statistics
import struct
import subprocess
import sys
import tempfile
import textwrap
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # also as a bare script

from benchmarks.cpu import process_cpu_ns
from benchmarks.repeats import REPEATS, best_and_median, ceiling_summary, load_average
from simbridge.endpoint.backends.ros2 import ros2_python

__all__ = ["run"]

if ros2_python() is None:  # benchmarks/run.py reports the suite as skipped
    raise ModuleNotFoundError("the ROS 2 venv (.venv-ros2) is missing: run `make ros2`")

SCALE = float(os.environ.get("SIMBRIDGE_BENCH_SCALE", "1"))
"""Multiplies the message counts (smaller for a quick look)."""
SIM_NODE = Path(__file__).with_name("bench_ros2_sim_node.py")
"""The publisher of the sim's own node rows (`simbridge sim --ros2`)."""
IDLE_END = 4.0
"""Seconds without a message after which a receiver stops counting (more than Fast DDS's
3 s heartbeat, so a sample repaired by reliability still counts)."""
LATENCY_COUNT = max(int(500 * SCALE), 20)
LATENCY_RATE = 200.0
ROUND_TRIP_TITLE = (
    "ROS 2 round trip through an rclpy echo node, beside rclpy -> echo -> rclpy in the same "
    "run (Twist, one at a time at 200 Hz)"
)


@dataclass(frozen=True, slots=True)
class Payload:
    """One benchmark payload: its type, CDR bytes, how many to send and the fewest rounds
    its rows take (whatever `repeats` says)."""

    label: str
    msg_type: str
    data: bytes
    count: int
    min_rounds: int = 1


def _cdr_string(text: str) -> bytes:
    raw = text.encode() + b"\0"
    return struct.pack("<I", len(raw)) + raw


def _pad(data: bytes, align: int) -> bytes:
    """Pad CDR body (after the 4-byte encapsulation header) to `align`."""
    return data + b"\0" * (-(len(data) - 4) % align)


def _image(width: int, height: int) -> bytes:
    """sensor_msgs/Image rgb8 in CDR: Header(stamp, frame_id), height, width, encoding,
    is_bigendian, step, data."""
    out = b"\x00\x01\x00\x00" + struct.pack("<iI", 0, 0) + _cdr_string("camera")
    out = _pad(out, 4) + struct.pack("<II", height, width) + _cdr_string("rgb8") + b"\x00"
    pixels = bytes(range(256)) * (width * height * 3 // 256)
    return _pad(out, 4) + struct.pack("<II", width * 3, len(pixels)) + pixels


def _twist(seq: float = 1.0) -> bytes:
    return b"\x00\x01\x00\x00" + struct.pack("<6d", seq, 2, 3, 4, 5, 6)


PAYLOADS = (
    # Rounds long enough that one scheduling stall of a few tens of ms on a shared machine
    # moves a round's rate little (30,000 Twists are ~0.25 s at the ceiling's rate, 600
    # images ~0.3 s; 10,000 Twists were 75 ms, where one 10 ms gap moved a share 13%), and
    # five rounds so the median has a middle
    Payload("Twist 48 B", "geometry_msgs/Twist", _twist(), max(int(30000 * SCALE), 10), 5),
    Payload(
        "Image 640x480 rgb8", "sensor_msgs/Image", _image(640, 480), max(int(600 * SCALE), 5), 5
    ),
)

_NODE_SCRIPT = textwrap.dedent(
    """
    import importlib, json, sys, time
    import rclpy
    import rclpy.executors

    def _quiet(kind, value, tb):  # stopped with SIGINT by the bench: no traceback
        stopped = (KeyboardInterrupt, rclpy.executors.ExternalShutdownException)
        if not issubclass(kind, stopped):  # rclpy.spin ends in the latter
            sys.__excepthook__(kind, value, tb)

    sys.excepthook = _quiet
    from rclpy.qos import QoSProfile, ReliabilityPolicy, HistoryPolicy

    def raw_publish(pub):  # what publish(bytes) ends in, without its checks, as the endpoint's
        return getattr(getattr(pub, "_Publisher__publisher", None), "publish_raw", pub.publish)

    role, topic, msg_type, count = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4])
    pkg, name = msg_type.split("/")
    cls = getattr(importlib.import_module(pkg + ".msg"), name)
    qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=max(count, 10),
                     reliability=ReliabilityPolicy.RELIABLE)
    rclpy.init()
    node = rclpy.create_node("bench_" + role)
    if role == "pub":
        payload = open(sys.argv[5], "rb").read()
        pub = node.create_publisher(cls, topic, qos)
        while pub.get_subscription_count() == 0:
            time.sleep(0.01)
        time.sleep(0.3)
        print("READY", flush=True)
        sys.stdin.readline()
        publish = raw_publish(pub)
        start = time.perf_counter()
        for _ in range(count):
            publish(payload)
        print(json.dumps({"sent": count, "start": start}), flush=True)
        sys.stdin.readline()
    elif role == "sub":
        times = []

        def got(_payload):
            # as the endpoint receives: one callback also takes what else is waiting (its
            # executor would rebuild the wait set per message); about twice the rate of
            # EventsExecutor's callback per message, measured here
            stamp, append, handle = time.perf_counter, times.append, sub.handle
            append(stamp())
            with handle:
                for _ in range(256):
                    if handle.take_message(cls, True) is None:
                        break
                    append(stamp())

        sub = node.create_subscription(cls, topic, got, qos, raw=True)
        executor = rclpy.executors.SingleThreadedExecutor()  # the endpoint's executor
        executor.add_node(node)
        print("READY", flush=True)
        deadline = time.time() + 60
        while sub.get_publisher_count() == 0 and time.time() < deadline:
            time.sleep(0.01)
        print("MATCHED", flush=True)
        while not times and time.time() < deadline:
            executor.spin_once(timeout_sec=0.05)
        last, last_len = time.time(), 0
        while len(times) < count and time.time() - last < %(idle)s:
            executor.spin_once(timeout_sec=0.05)
            if len(times) != last_len:
                last, last_len = time.time(), len(times)
        print(json.dumps({"times": [times[0], times[-1]] if times else [], "count": len(times)}),
              flush=True)
    elif role == "ping":  # the reference round trip: publish, wait for the echo, pace
        import struct
        payload = bytearray(open(sys.argv[5], "rb").read())
        pub = node.create_publisher(cls, topic, qos)
        back = {}

        def got(data):  # linear.x (after the CDR header) carries the ping's number
            back[struct.unpack_from("<d", data, 4)[0]] = time.perf_counter()

        sub = node.create_subscription(cls, topic + "_back", got, qos, raw=True)
        executor = rclpy.executors.SingleThreadedExecutor()
        executor.add_node(node)
        deadline = time.time() + 60
        while (pub.get_subscription_count() == 0 or sub.get_publisher_count() == 0) and (
                time.time() < deadline):
            time.sleep(0.01)
        time.sleep(1.0)
        print("READY", flush=True)
        sys.stdin.readline()
        publish = raw_publish(pub)
        rtts = []
        for seq in range(count):
            struct.pack_into("<d", payload, 4, float(seq))
            sent = time.perf_counter()
            publish(bytes(payload))
            while float(seq) not in back and time.perf_counter() - sent < 1.0:
                executor.spin_once(timeout_sec=0.05)
            if float(seq) in back:
                rtts.append(back[float(seq)] - sent)
            time.sleep(max(0.0, sent + 1.0 / %(rate)s - time.perf_counter()))
        print(json.dumps({"rtts": rtts}), flush=True)
        sys.stdin.readline()
    else:  # echo: topic -> topic + "_back", raw
        back = node.create_publisher(cls, topic + "_back", qos)
        node.create_subscription(cls, topic, back.publish, qos, raw=True)
        print("READY", flush=True)
        rclpy.spin(node)
    node.destroy_node()
    rclpy.try_shutdown()
    """
)


class _Proc:
    """A ROS 2 venv process whose stdout lines are read on a thread."""

    def __init__(self, args: list[str], env: dict[str, str]) -> None:
        from tests.ros2support import require_ros2

        self.proc = subprocess.Popen(
            [str(require_ros2()), *args],
            env=env,
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
            start_new_session=True,
        )
        self.role = args[1] if len(args) > 1 else args[0]
        self.lines: queue.Queue[str] = queue.Queue()
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        """Queue the node's protocol lines (READY, MATCHED, JSON); anything else, such as a
        Fast DDS log line (`Failed init_port ...` when another process holds a shared-memory
        port), goes to stderr instead of being taken for an answer."""
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            text = line.strip()
            if text in ("READY", "MATCHED") or text.startswith("{"):
                self.lines.put(text)
            elif text:
                print(f"[bench node {self.role}] {text}", file=sys.stderr, flush=True)

    def line(self, timeout: float = 60.0) -> str:
        try:
            return self.lines.get(timeout=timeout)
        except queue.Empty:
            raise RuntimeError(f"{self.proc.args!r} said nothing within {timeout} s") from None

    def tell(self, text: str = "go") -> None:
        assert self.proc.stdin is not None
        self.proc.stdin.write(text + "\n")
        self.proc.stdin.flush()

    def stop(self) -> None:
        from tests.ros2support import Ros2Process

        holder = Ros2Process.__new__(Ros2Process)
        holder.proc = self.proc
        holder.stop()


class _CpuSampler:
    """Every thread's CPU time of some processes, sampled every 10 ms on a thread (whose
    own time is left out) until `span` says how much each spent between two instants."""

    def __init__(self, pids: dict[str, int]) -> None:
        self.pids = pids
        self.samples: list[tuple[float, dict[str, int]]] = []
        self._own = -1
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()
        time.sleep(0.05)  # a sample before the round starts

    def _run(self) -> None:
        self._own = threading.get_native_id()
        while not self._stop.is_set():
            now = time.perf_counter()
            cpu = {k: process_cpu_ns(p, self._own) for k, p in self.pids.items()}
            self.samples.append((now, cpu))
            self._stop.wait(0.01)

    def _at(self, t: float) -> dict[str, float]:
        samples = self.samples
        for (t0, a), (t1, b) in itertools.pairwise(samples):
            if t1 >= t:
                f = min(max((t - t0) / (t1 - t0), 0.0), 1.0) if t1 > t0 else 1.0
                return {k: a[k] + f * (b[k] - a[k]) for k in a}
        return {k: float(v) for k, v in samples[-1][1].items()}

    def span(self, start: float, last: float, count: int) -> dict[str, float]:
        """Stop sampling; microseconds of CPU per message of each process in [start, last]."""
        self._stop.set()
        self._thread.join()
        a, b = self._at(start), self._at(last)
        return {k: (b[k] - a[k]) / 1e3 / max(count, 1) for k in a}


def _row(direction: str, p: Payload, received: int, start: float, last: float) -> dict[str, Any]:
    """Messages per second from the first one sent (`start`) to the last one received
    (`last`): perf_counter is CLOCK_MONOTONIC, the same clock in every process."""
    span = last - start
    rate = received / span if received and span > 0 else 0.0
    return {
        "direction": direction,
        "payload": p.label,
        "sent": p.count,
        "received": received,
        "msg_per_s": rate,
        "mb_per_s": rate * len(p.data) / 1e6,
        "loss": 1 - received / p.count,
    }


def _node(env: dict[str, str], script: Path, role: str, topic: str, p: Payload,
          *, payload_file: Path | None = None) -> _Proc:  # fmt: skip
    args = [str(script), role, topic, p.msg_type, str(p.count)]
    if payload_file is not None:
        args.append(str(payload_file))
    return _Proc(args, env)


def _ceiling(env: dict[str, str], script: Path, data: Path, p: Payload, topic: str,
             *, cpu: bool = False, publisher: Path | None = None) -> Any:  # fmt: skip
    """The rclpy -> rclpy row; with `publisher` (SIM_NODE) the sim's own node's row."""
    sub = _node(env, script, "sub", topic, p)
    pub = _node(env, publisher or script, "pub", topic, p, payload_file=data)
    sampler = None
    try:
        assert sub.line() == "READY"
        assert pub.line() == "READY"
        assert sub.line() == "MATCHED"
        if cpu:
            sampler = _CpuSampler({"publisher": pub.proc.pid, "subscriber": sub.proc.pid})
        pub.tell()
        result = json.loads(sub.line(timeout=120))
        start = json.loads(pub.line())["start"]
    finally:
        pub.stop()
        sub.stop()
    last = result["times"][1] if result["times"] else start
    direction = "sim -> ros2 (in-process node)" if publisher else "rclpy -> rclpy (ceiling)"
    row = _row(direction, p, result["count"], start, last)
    if sampler is not None:
        row["cpu_us"] = sampler.span(start, last, result["count"])
    return row


def _connector(port: int, count: int) -> Any:
    from simbridge.connector import Connector, ConnectorOptions

    options = ConnectorOptions(publish_queue_size=count + 10, subscribe_queue_size=count + 10)
    return Connector("127.0.0.1", port, options).connect(wait=10)


def _sim_to_ros(env: dict[str, str], script: Path, port: int, p: Payload, topic: str,
                *, endpoint_pid: int | None = None) -> Any:  # fmt: skip
    conn = _connector(port, p.count)
    sub = _node(env, script, "sub", topic, p)
    sampler = None
    try:
        publisher = conn.register_publisher(
            topic, p.msg_type, queue_size=p.count, report_subscribers=True
        )
        assert sub.line() == "READY"
        assert sub.line() == "MATCHED"
        deadline = time.monotonic() + 30
        while (publisher.subscriber_count or 0) < 1 and time.monotonic() < deadline:
            time.sleep(0.01)
        time.sleep(0.3)
        if endpoint_pid is not None:
            pids = {"connector": os.getpid(), "endpoint": endpoint_pid, "subscriber": sub.proc.pid}
            sampler = _CpuSampler(pids)
        start = time.perf_counter()
        for _ in range(p.count):
            publisher.publish(p.data)
        result = json.loads(sub.line(timeout=120))
    finally:
        sub.stop()
        conn.close()
    last = result["times"][1] if result["times"] else start
    row = _row("sim -> ros2 (connector -> endpoint)", p, result["count"], start, last)
    if sampler is not None:
        row["cpu_us"] = sampler.span(start, last, result["count"])
    return row


def _ros_to_sim(env: dict[str, str], script: Path, data: Path, port: int, p: Payload,
                *, topic: str, endpoint_pid: int | None = None) -> Any:  # fmt: skip
    conn = _connector(port, p.count)
    times: list[float] = []
    sizes: set[int] = set()

    def got(payload: bytes) -> None:
        times.append(time.perf_counter())
        sizes.add(len(payload))

    conn.subscribe(topic, p.msg_type, got, raw=True, queue_size=p.count + 10)
    time.sleep(0.5)
    pub = _node(env, script, "pub", topic, p, payload_file=data)
    sampler = None
    try:
        assert pub.line() == "READY"
        if endpoint_pid is not None:
            pids = {"publisher": pub.proc.pid, "endpoint": endpoint_pid, "connector": os.getpid()}
            sampler = _CpuSampler(pids)
        pub.tell()
        deadline = time.monotonic() + 60
        while not times and time.monotonic() < deadline:
            time.sleep(0.01)
        while len(times) < p.count:
            before = len(times)
            time.sleep(IDLE_END)
            if len(times) == before:
                break
        start = json.loads(pub.line())["start"]
    finally:
        pub.stop()
        conn.close()
    if sizes and max(sizes) - min(sizes) > 4:
        raise RuntimeError(f"payload sizes {sizes} differ from the {len(p.data)} sent")
    last = times[-1] if times else start
    row = _row("ros2 -> sim (endpoint -> connector)", p, len(times), start, last)
    if sampler is not None:
        row["cpu_us"] = sampler.span(start, last, len(times))
    return row


def _latency(env: dict[str, str], script: Path, port: int, topic: str) -> list[float]:
    """Round trips sim -> endpoint -> rclpy echo -> endpoint -> sim, one at a time (s)."""
    p = Payload("Twist 48 B", "geometry_msgs/Twist", _twist(), LATENCY_COUNT)
    conn = _connector(port, p.count)
    echo = _node(env, script, "echo", topic, p)
    sent: dict[int, float] = {}
    rtts: list[float] = []

    def back(payload: bytes) -> None:
        seq = int(struct.unpack_from("<d", payload, 4)[0])
        if seq in sent:
            rtts.append(time.perf_counter() - sent[seq])

    try:
        assert echo.line() == "READY"
        conn.subscribe(topic + "_back", p.msg_type, back, raw=True)
        publisher = conn.register_publisher(topic, p.msg_type, report_subscribers=True)
        deadline = time.monotonic() + 30
        while (publisher.subscriber_count or 0) < 1 and time.monotonic() < deadline:
            time.sleep(0.01)
        time.sleep(1.0)
        for seq in range(p.count):
            sent[seq] = time.perf_counter()
            publisher.publish(_twist(float(seq)))
            time.sleep(1.0 / LATENCY_RATE)
        time.sleep(IDLE_END)
    finally:
        echo.stop()
        conn.close()
    return rtts


def _rclpy_latency(env: dict[str, str], script: Path, data: Path, topic: str) -> list[float]:
    """The reference: an rclpy pinger -> the same kind of rclpy echo -> the pinger (s)."""
    p = Payload("Twist 48 B", "geometry_msgs/Twist", _twist(), LATENCY_COUNT)
    echo = _node(env, script, "echo", topic, p)
    ping = None
    try:
        assert echo.line() == "READY"
        ping = _node(env, script, "ping", topic, p, payload_file=data)
        assert ping.line() == "READY"
        ping.tell()
        rtts: list[float] = json.loads(ping.line(timeout=60 + 2 * p.count / LATENCY_RATE))["rtts"]
    finally:
        if ping is not None:
            ping.stop()
        echo.stop()
    return rtts


def latency_row(path: str, runs: list[list[float]], reference: list[list[float]],
                load: float) -> dict[str, Any]:  # fmt: skip
    """One round-trip row: p50, p99 and max of each run in ms (best and median over the
    runs), and p50 and p99 against the reference run of the same round (median ratio)."""
    row: dict[str, Any] = {"path": path, "messages": LATENCY_COUNT, "load_1min": load}
    row["returned_worst"] = min(len(rtts) for rtts in runs)
    for figure, q in (("p50_ms", 0.5), ("p99_ms", 0.99), ("max_ms", 1.0)):
        values = [_percentile(rtts, q) for rtts in runs]
        row[f"{figure}_best"], row[f"{figure}_median"] = best_and_median(values, True)
        if figure != "max_ms":
            pairs = zip(runs, reference, strict=True)
            ratios = [_percentile(a, q) / _percentile(b, q) for a, b in pairs]
            row[f"{figure}_vs_rclpy"] = statistics.median(ratios)
    return row


def _percentile(rtts: list[float], q: float) -> float:
    """The `q` quantile of round trips given in s, in ms (nan when none came back)."""
    if not rtts:
        return float("nan")
    ordered = sorted(rtts)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))] * 1e3


def _memory_mb() -> str:
    """The endpoint's budget: one client's share (an eighth) holds the largest burst with
    a fifth to spare, so a Connector that falls behind (a loaded machine) gets every
    message late rather than some dropped (the default 1 GiB holds ~140 images)."""
    burst = max(p.count * len(p.data) for p in PAYLOADS) * 1.2 / 2**20
    return str(max(1024, 8 * int(burst + 1)))


def run(repeats: int = REPEATS) -> dict[str, list[dict[str, Any]]]:
    """Ceiling, endpoint and in-process node rows per payload in `repeats` interleaved
    rounds, or the payload's `min_rounds` if more (each share taken against the same
    round's ceiling; rows give best and median), then the latency rows. Bounded: at most
    30,000 messages per row, each receiver stops after IDLE_END s without a message."""
    from tests.ros2support import child_env, start_endpoint

    env = child_env()
    rows: list[dict[str, Any]] = []
    latencies: list[list[float]] = []
    reference: list[list[float]] = []
    with tempfile.TemporaryDirectory() as tmp:
        script = Path(tmp, "bench_ros2_node.py")
        script.write_text(_NODE_SCRIPT % {"idle": IDLE_END, "rate": LATENCY_RATE})
        endpoint, port = start_endpoint("--idle-timeout", "0", "--max-memory-mb", _memory_mb())
        try:
            for i, p in enumerate(PAYLOADS):
                data = Path(tmp, f"payload{i}.bin")
                data.write_bytes(p.data)
                rounds: list[list[dict[str, Any]]] = []
                load = load_average()
                for r in range(max(repeats, p.min_rounds)):
                    topic = f"/bench/p{i}r{r}"
                    rounds.append(
                        [
                            _ceiling(env, script, data, p, topic + "/ceiling"),
                            _sim_to_ros(env, script, port, p, topic + "/sim_to_ros"),
                            _ros_to_sim(env, script, data, port, p, topic=topic + "/ros_to_sim"),
                            _ceiling(env, script, data, p, topic + "/node", publisher=SIM_NODE),
                        ]
                    )
                rows += [
                    ceiling_summary(rounds, k, load, len(p.data), "median")
                    for k in range(len(rounds[0]))
                ]
            twist = Path(tmp, "twist.bin")
            twist.write_bytes(_twist())
            loads = [load_average()]
            for r in range(repeats):  # alternating, each ratio against its own round
                reference.append(_rclpy_latency(env, script, twist, f"/bench/rt{r}/rclpy"))
                if r == 0:
                    loads.append(load_average())
                latencies.append(_latency(env, script, port, f"/bench/rt{r}/endpoint"))
        finally:
            endpoint.stop()
    return {
        "ROS 2 backend against the rclpy ceiling, same run (target: >= 90%, zero loss)": rows,
        ROUND_TRIP_TITLE: [
            latency_row("rclpy -> rclpy echo -> rclpy", reference, reference, loads[0]),
            latency_row(
                "sim -> endpoint -> rclpy echo -> endpoint -> sim", latencies, reference, loads[1]
            ),
        ],
    }


def cpu_accounting(
    payloads: tuple[Payload, ...] = PAYLOADS, rounds: int = 5
) -> list[dict[str, Any]]:
    """Per payload, its four rows (ceiling, sim -> ros2, ros2 -> sim, the sim's own node) in
    `rounds` interleaved rounds with each process's CPU per message: per row the medians of the rate
    and of each process's CPU, their sum, the rate that sum allows on this machine's cores,
    and the share of the ceiling it allows (the same round's ceiling sum over the row's)."""
    from tests.ros2support import child_env, start_endpoint

    env = child_env()
    cores = os.cpu_count() or 1
    rows: list[dict[str, Any]] = []
    with tempfile.TemporaryDirectory() as tmp:
        script = Path(tmp, "bench_ros2_node.py")
        script.write_text(_NODE_SCRIPT % {"idle": IDLE_END, "rate": LATENCY_RATE})
        endpoint, port = start_endpoint("--idle-timeout", "0", "--max-memory-mb", _memory_mb())
        pid = endpoint.proc.pid
        try:
            for i, p in enumerate(payloads):
                data = Path(tmp, f"payload{i}.bin")
                data.write_bytes(p.data)
                load = load_average()
                runs: list[list[dict[str, Any]]] = []
                for r in range(rounds):
                    topic = f"/bench/cpu{i}r{r}"
                    ceiling = _ceiling(env, script, data, p, topic + "/ceiling", cpu=True)
                    out = _sim_to_ros(env, script, port, p, topic + "/sim_to_ros", endpoint_pid=pid)
                    back = _ros_to_sim(
                        env, script, data, port, p, topic=topic + "/ros_to_sim", endpoint_pid=pid
                    )
                    node = _ceiling(
                        env, script, data, p, topic + "/node", cpu=True, publisher=SIM_NODE
                    )
                    runs.append([ceiling, out, back, node])
                rows += [_cpu_row(runs, k, load, cores) for k in range(4)]
        finally:
            endpoint.stop()
    return rows


def _cpu_row(runs: list[list[dict[str, Any]]], k: int, load: float, cores: int) -> dict[str, Any]:
    """Row `k` of `runs` (each round's ceiling first) summed up: medians over the rounds,
    and each round's rate and CPU sum."""
    series = [run[k] for run in runs]
    cpu = {
        name: statistics.median(row["cpu_us"][name] for row in series)
        for name in series[0]["cpu_us"]
    }
    total = statistics.median(sum(row["cpu_us"].values()) for row in series)
    return {
        "direction": series[0]["direction"],
        "payload": series[0]["payload"],
        "load_1min": load,
        "msg_per_s_median": statistics.median(row["msg_per_s"] for row in series),
        "of_ceiling_median": statistics.median(
            row["msg_per_s"] / max(run[0]["msg_per_s"], 1e-9)
            for row, run in zip(series, runs, strict=True)
        ),
        "loss_worst": max(row["loss"] for row in series),
        "cpu_us_per_msg_median": {name: round(v, 1) for name, v in cpu.items()},
        "cpu_us_sum_median": round(total, 1),
        # each round's rate and CPU sum: the spread behind the medians
        "rounds_msg_per_s_cpu_us": [
            (round(row["msg_per_s"]), round(sum(row["cpu_us"].values()), 1)) for row in series
        ],
        f"bound_msg_per_s_{cores}_cores": cores / total * 1e6 if total else 0.0,
        # the share of the ceiling that CPU alone allows (both at their bound)
        "bound_of_ceiling_median": statistics.median(
            sum(run[0]["cpu_us"].values()) / max(sum(row["cpu_us"].values()), 1e-9)
            for row, run in zip(series, runs, strict=True)
        ),
    }


if __name__ == "__main__":
    from benchmarks.usage import exit_on_help

    exit_on_help(
        __doc__,
        "  --cpu [twist|image]   only the throughput rows (of one payload), with CPU per\n"
        "                        message per process",
    )
    if "--cpu" in sys.argv[1:]:
        wanted = {a for a in sys.argv[1:] if a != "--cpu"}
        chosen = tuple(p for p in PAYLOADS if not wanted or p.label.split()[0].lower() in wanted)
        if wanted and not chosen:
            raise SystemExit(f"--cpu takes twist or image, not {' '.join(sorted(wanted))}")
        for row in cpu_accounting(chosen):
            print(row, flush=True)
        raise SystemExit(0)
    for title, table in run().items():
        print(title)
        for row in table:
            print(row, flush=True)
