"""`simbridge topic` and `simbridge service`: ROS graph tools that work through an endpoint.

Messages are read and printed with the registry of the endpoint's protocol, so against
a ROS 2 endpoint the YAML uses ROS 2 field names (`stamp: {sec, nanosec}`, no `seq`,
CameraInfo `k`).
"""

from __future__ import annotations

import argparse
import sys

from simbridge.errors import ConnectorError

from .common import add_endpoint_arg, connect, print_msg

__all__ = ["add_parser"]


def run_topic(args: argparse.Namespace) -> int:
    import queue
    import time

    with connect(args) as conn:
        registry = conn.registry
        if args.action == "list":
            topics = conn.topic_list(timeout=args.connect_timeout)
            width = max((len(t) for t in topics), default=0)
            for name, name_type in sorted(topics.items()):
                print(f"{name:<{width}}  {name_type}" if args.verbose else name)
            return 0
        msg_type: str | None = args.type or conn.topic_list(timeout=args.connect_timeout).get(
            args.topic
        )
        if msg_type is None:
            raise ConnectorError(
                f"topic {args.topic!r} is not in the graph; pass its type with --type"
            )
        if args.action == "pub":
            msg = registry.from_yaml(msg_type, args.data or "")
            pub = conn.register_publisher(args.topic, msg_type, latch=args.latch)
            period = 1.0 / args.rate if args.rate else 0.0
            sent = 0
            while True:
                pub.publish(msg)
                sent += 1
                if not period or (args.count and sent >= args.count):
                    break
                time.sleep(period)
            conn.flush(timeout=5)
            if args.latch and not period:
                time.sleep(args.linger)
            print(f"published {sent} message(s) on {args.topic}", file=sys.stderr)
            return 0
        inbox: queue.Queue[object] = queue.Queue(maxsize=10_000)
        raw = args.action == "hz"
        conn.subscribe(args.topic, msg_type, inbox.put, raw=raw)
        deadline = time.monotonic() + args.duration if args.duration else None
        if args.action == "echo":
            shown = 0
            while args.count == 0 or shown < args.count:
                remaining = None if deadline is None else deadline - time.monotonic()
                if remaining is not None and remaining <= 0:
                    break
                try:
                    msg = inbox.get(timeout=remaining)
                except queue.Empty:
                    break
                print_msg(registry, msg, args.no_arr)
                shown += 1
            return 0 if shown or args.count == 0 else 1
        stamps: list[float] = []
        next_report = time.monotonic() + 1.0
        while deadline is None or time.monotonic() < deadline:
            try:
                inbox.get(timeout=0.1)
                stamps.append(time.monotonic())
            except queue.Empty:
                pass
            if time.monotonic() >= next_report:
                next_report += 1.0
                window = stamps[-args.window :]
                if len(window) > 1:
                    rate = (len(window) - 1) / (window[-1] - window[0])
                    print(f"average rate: {rate:.3f}  (window {len(window)})", flush=True)
                else:
                    print("no new messages", flush=True)
        return 0


def run_service(args: argparse.Namespace) -> int:
    with connect(args) as conn:
        registry = conn.registry
        info = registry.service(args.type)
        request = registry.from_yaml(info.request, args.data or "")
        conn.register_ros_service(args.service, info.name)
        response = conn.call(args.service, request, timeout=args.timeout)
    print_msg(registry, response, no_arr=False)
    return 0


def _connect_timeout_arg(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--connect-timeout",
        type=float,
        default=5.0,
        metavar="SECONDS",
        help="fail when the endpoint has not answered within SECONDS (default 5)",
    )


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    topic = sub.add_parser("topic", help="list, echo, publish or measure topics via an endpoint")
    tsub = topic.add_subparsers(dest="action", required=True)
    t_list = tsub.add_parser("list", help="topics in the graph")
    t_list.add_argument("-v", "--verbose", action="store_true", help="show types too")
    t_echo = tsub.add_parser("echo", help="print messages on a topic")
    t_echo.add_argument("topic", help="topic name, e.g. /joint_states")
    t_echo.add_argument("-n", "--count", type=int, default=0, help="stop after N messages")
    t_echo.add_argument("--no-arr", action="store_true", help="summarise arrays")
    t_pub = tsub.add_parser("pub", help="publish a message given as YAML")
    t_pub.add_argument("topic", help="topic name, e.g. /cmd_vel")
    t_pub.add_argument("type", nargs="?", help="message type, e.g. geometry_msgs/Twist")
    t_pub.add_argument("data", nargs="?", default="", help="YAML, e.g. '{linear: {x: 0.5}}'")
    t_pub.add_argument("-r", "--rate", type=float, default=0.0, help="repeat at HZ")
    t_pub.add_argument("-n", "--count", type=int, default=0, help="with --rate: stop after N")
    t_pub.add_argument(
        "-l", "--latch", action="store_true", help="latch: late subscribers get the last message"
    )
    t_pub.add_argument("--linger", type=float, default=1.0, help="seconds to stay up when latched")
    t_hz = tsub.add_parser("hz", help="print the publishing rate of a topic")
    t_hz.add_argument("topic", help="topic name, e.g. /scan")
    t_hz.add_argument(
        "-w",
        "--window",
        type=int,
        default=100,
        metavar="N",
        help="average over the last N messages (default 100)",
    )
    for p in (t_list, t_echo, t_pub, t_hz):
        add_endpoint_arg(p)
        _connect_timeout_arg(p)
    for p in (t_echo, t_hz):
        p.add_argument("--type", help="message type (default: looked up in the topic list)")
        p.add_argument("--duration", type=float, default=0.0, help="stop after S seconds")
    t_pub.set_defaults(func=run_topic, duration=0.0)
    for p in (t_list, t_echo, t_hz):
        p.set_defaults(func=run_topic)

    svc = sub.add_parser("service", help="call a ROS service via an endpoint")
    ssub = svc.add_subparsers(dest="action", required=True)
    s_call = ssub.add_parser("call", help="call a service with a YAML request")
    s_call.add_argument("service", help="service name, e.g. /reset_odometry")
    s_call.add_argument("type", help="service type, e.g. std_srvs/SetBool")
    s_call.add_argument("data", nargs="?", default="", help="YAML request, e.g. '{data: true}'")
    s_call.add_argument(
        "--timeout",
        type=float,
        default=10.0,
        metavar="SECONDS",
        help="fail when the service has not answered within SECONDS (default 10)",
    )
    add_endpoint_arg(s_call)
    _connect_timeout_arg(s_call)
    s_call.set_defaults(func=run_service)
