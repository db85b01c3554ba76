"""The `simbridge` command line: endpoint, topic/service tools, messages, URDF, sim, demos.

Subcommand implementations are imported lazily so `simbridge msg md5` stays quick.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import logging
import sys
from collections.abc import Sequence
from typing import TYPE_CHECKING

from simbridge.errors import ConnectorError, SimbridgeError

if TYPE_CHECKING:
    from simbridge.connector import Connector
    from simbridge.messages import MessageRegistry

__all__ = ["main"]

log = logging.getLogger("simbridge")


def _endpoint_address(text: str) -> tuple[str, int]:
    host, sep, port = text.rpartition(":")
    if not sep or not port.isdigit():
        raise argparse.ArgumentTypeError(
            f"--endpoint {text!r}: expected HOST:PORT, e.g. 127.0.0.1:10000"
        )
    return host or "127.0.0.1", int(port)


def _add_endpoint_arg(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--endpoint",
        type=_endpoint_address,
        default=("127.0.0.1", 10000),
        metavar="HOST:PORT",
        help="endpoint to connect to (default 127.0.0.1:10000)",
    )


def _cmd_endpoint(args: argparse.Namespace) -> int:
    from simbridge.endpoint import EndpointOptions, EndpointServer, make_backend

    if args.msg_path:
        from simbridge.messages import default_registry

        default_registry().load_packages(*args.msg_path)
    backend = make_backend(args.backend, node_name=args.node_name, ros_args=args.ros_args)

    async def run() -> None:
        # Precedence: command-line flag, then the original node's ~tcp_ip/~tcp_port, then default.
        host, port = args.host, args.port
        if args.backend == "ros1":
            from simbridge.endpoint.backends.ros1_node import read_drop_in_params

            await backend.start()
            param_host, param_port = read_drop_in_params()
            host = host if host is not None else param_host
            port = port if port is not None else param_port
        options = EndpointOptions(
            host=host if host is not None else "127.0.0.1",
            port=port if port is not None else 10000,
            max_frame_size=int(args.max_frame_mb * 1024 * 1024),
            idle_timeout=args.idle_timeout,
            max_clients=args.max_clients,
        )
        server = EndpointServer(options, backend)
        await server.start()
        print(
            f"simbridge endpoint listening on {options.host}:{server.port} "
            f"(backend {backend.name})",
            flush=True,
        )
        try:
            await server.serve_forever()
        finally:
            await server.close()

    with contextlib.suppress(KeyboardInterrupt):
        asyncio.run(run())
    return 0


def _connect(args: argparse.Namespace) -> Connector:
    from simbridge.connector import Connector

    host, port = args.endpoint
    return Connector(host, port).connect(wait=args.connect_timeout)


def _print_msg(registry: MessageRegistry, msg: object, no_arr: bool) -> None:
    import yaml

    data = registry.to_dict(msg)
    shown = _strip_arrays(data) if no_arr else data
    print(yaml.safe_dump(shown, sort_keys=False, default_flow_style=None).rstrip())
    print("---", flush=True)


def _strip_arrays(value: object) -> object:
    if isinstance(value, dict):
        return {k: _strip_arrays(v) for k, v in value.items()}
    if isinstance(value, list | bytes) and len(value) > 8:
        return f"<array of {len(value)}>"
    if isinstance(value, list):
        return [_strip_arrays(v) for v in value]
    return value


def _cmd_topic(args: argparse.Namespace) -> int:
    import queue
    import time

    from simbridge.messages import default_registry

    registry = default_registry()
    with _connect(args) as conn:
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
                _print_msg(registry, msg, args.no_arr)
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


def _cmd_service(args: argparse.Namespace) -> int:
    from simbridge.messages import default_registry

    registry = default_registry()
    info = registry.service(args.type)
    request = registry.from_yaml(info.request, args.data or "")
    with _connect(args) as conn:
        conn.register_ros_service(args.service, info.name)
        response = conn.call(args.service, request, timeout=args.timeout)
    _print_msg(registry, response, no_arr=False)
    return 0


def _cmd_msg(args: argparse.Namespace) -> int:
    from simbridge.messages import default_registry

    registry = default_registry()
    if args.msg_path:
        registry.load_packages(*args.msg_path)
    if args.action == "genpy":
        from pathlib import Path

        from simbridge.endpoint.backends.ros1_genpy import generate_python_messages

        services = [t for t in args.types if registry.has_service(t)]
        messages = [t for t in args.types if not registry.has_service(t)]
        env = generate_python_messages(registry, services, Path(args.out).resolve(), messages)
        print(f"export ROS_PACKAGE_PATH={env['ROS_PACKAGE_PATH']}:$ROS_PACKAGE_PATH")
        print(f"export PYTHONPATH={env['PYTHONPATH']}:$PYTHONPATH")
    elif args.action == "md5":
        print(registry.md5(args.type))
    elif args.action == "show":
        print(registry.show(args.type).rstrip())
    else:
        for name in registry.service_names() if args.services else registry.names():
            print(name)
    return 0


def _cmd_urdf(args: argparse.Namespace) -> int:
    import json

    from simbridge.sim.urdf import urdf_check, urdf_fk

    if args.action == "check":
        print(urdf_check(args.file, search_paths=args.search_path).rstrip())
        return 0
    poses = urdf_fk(args.file, args.set, search_paths=args.search_path)
    if args.json:
        print(json.dumps(poses, indent=None if args.compact else 2))
    else:
        width = max((len(link) for link in poses), default=0)
        for link, pose in poses.items():
            xyz = " ".join(f"{v: .6f}" for v in pose["xyz"])
            quat = " ".join(f"{v: .6f}" for v in pose["quat_xyzw"])
            print(f"{link:<{width}}  xyz [{xyz}]  quat_xyzw [{quat}]")
    return 0


def _cmd_sim(args: argparse.Namespace) -> int:
    from simbridge.sim.ros import run_scene

    endpoint = f"{args.endpoint[0]}:{args.endpoint[1]}" if args.endpoint else None
    stats = run_scene(
        args.scene,
        endpoint=endpoint,
        duration=args.duration,
        realtime_factor=args.realtime,
        viewer=args.viewer,
    )
    print(
        f"simulated {stats.sim_time:.3f} s in {stats.wall_time:.3f} s wall "
        f"({stats.steps} steps, {stats.realtime_factor:.2f}x real time)"
    )
    return 0


def _cmd_demo(args: argparse.Namespace) -> int:
    if args.name == "bridge":
        from simbridge.apps.bridge_demo import run_bridge_demo

        return 0 if run_bridge_demo() else 1
    if args.name == "mobile-robot":
        from simbridge.apps.mobile_robot import main as mobile_robot_main

        forwarded = ["--side", str(args.side), "--realtime", str(args.realtime or 0.0)]
        return mobile_robot_main([*forwarded, "--json"] if args.json else forwarded)
    from simbridge.apps import pick_and_place_main

    forwarded = ["--backend", args.backend]
    if args.json:
        forwarded.append("--json")
    if args.video:
        forwarded += ["--video", args.video]
    if args.seed is not None:
        forwarded += ["--seed", str(args.seed)]
    return pick_and_place_main(forwarded)


def build_parser() -> argparse.ArgumentParser:
    """The full argument parser."""
    parser = argparse.ArgumentParser(prog="simbridge", description=__doc__)
    parser.add_argument(
        "--log-level", default=None, help="DEBUG, INFO, WARNING or ERROR (default INFO for servers)"
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    ep = sub.add_parser("endpoint", help="run the ROS-TCP endpoint (TCP server on the ROS side)")
    ep.add_argument(
        "--host",
        default=None,
        help="address to bind (default: ros1 param ~tcp_ip, else 127.0.0.1)",
    )
    ep.add_argument(
        "--port",
        type=int,
        default=None,
        help="TCP port (default: ros1 param ~tcp_port, else 10000; 0 = any free port)",
    )
    ep.add_argument("--backend", choices=["local", "ros1"], default="local")
    ep.add_argument("--node-name", default="/simbridge_endpoint", help="ROS node name (ros1)")
    ep.add_argument("--max-frame-mb", type=float, default=64.0, help="largest accepted frame")
    ep.add_argument(
        "--max-clients", type=int, default=1000, help="connections served at once (default 1000)"
    )
    ep.add_argument(
        "--idle-timeout",
        type=float,
        default=10.0,
        help="close clients silent this long (s); 0 disables",
    )
    ep.add_argument(
        "--msg-path",
        action="append",
        default=[],
        metavar="DIR",
        help="directory of .msg/.srv/.action packages (repeatable)",
    )
    ep.set_defaults(func=_cmd_endpoint)

    topic = sub.add_parser("topic", help="list, echo, publish or measure topics via an endpoint")
    tsub = topic.add_subparsers(dest="action", required=True)
    t_list = tsub.add_parser("list", help="topics in the graph")
    t_list.add_argument("-v", "--verbose", action="store_true", help="show types too")
    t_echo = tsub.add_parser("echo", help="print messages on a topic")
    t_echo.add_argument("topic")
    t_echo.add_argument("-n", "--count", type=int, default=0, help="stop after N messages")
    t_echo.add_argument("--no-arr", action="store_true", help="summarise arrays")
    t_pub = tsub.add_parser("pub", help="publish a message given as YAML")
    t_pub.add_argument("topic")
    t_pub.add_argument("type", nargs="?", help="message type, e.g. geometry_msgs/Twist")
    t_pub.add_argument("data", nargs="?", default="", help="YAML, e.g. '{linear: {x: 0.5}}'")
    t_pub.add_argument("-r", "--rate", type=float, default=0.0, help="repeat at HZ")
    t_pub.add_argument("-n", "--count", type=int, default=0, help="with --rate: stop after N")
    t_pub.add_argument("-l", "--latch", action="store_true")
    t_pub.add_argument("--linger", type=float, default=1.0, help="seconds to stay up when latched")
    t_hz = tsub.add_parser("hz", help="print the publishing rate of a topic")
    t_hz.add_argument("topic")
    t_hz.add_argument("-w", "--window", type=int, default=100)
    for p in (t_list, t_echo, t_pub, t_hz):
        _add_endpoint_arg(p)
        p.add_argument("--connect-timeout", type=float, default=5.0)
    for p in (t_echo, t_hz):
        p.add_argument("--type", help="message type (default: looked up in the topic list)")
        p.add_argument("--duration", type=float, default=0.0, help="stop after S seconds")
    t_pub.set_defaults(func=_cmd_topic, duration=0.0)
    for p in (t_list, t_echo, t_hz):
        p.set_defaults(func=_cmd_topic)

    svc = sub.add_parser("service", help="call a ROS service via an endpoint")
    ssub = svc.add_subparsers(dest="action", required=True)
    s_call = ssub.add_parser("call", help="call a service with a YAML request")
    s_call.add_argument("service")
    s_call.add_argument("type", help="service type, e.g. std_srvs/SetBool")
    s_call.add_argument("data", nargs="?", default="", help="YAML request, e.g. '{data: true}'")
    s_call.add_argument("--timeout", type=float, default=10.0)
    _add_endpoint_arg(s_call)
    s_call.add_argument("--connect-timeout", type=float, default=5.0)
    s_call.set_defaults(func=_cmd_service)

    msg = sub.add_parser("msg", help="inspect message types")
    msub = msg.add_subparsers(dest="action", required=True)
    m_show = msub.add_parser("show", help="fields of a message or service type")
    m_show.add_argument("type")
    m_md5 = msub.add_parser("md5", help="genmsg md5sum of a type")
    m_md5.add_argument("type")
    m_list = msub.add_parser("list", help="every known type")
    m_list.add_argument("--services", action="store_true")
    m_genpy = msub.add_parser(
        "genpy",
        help="generate ROS 1 Python modules (for rostopic/rosservice) for types Debian lacks",
    )
    m_genpy.add_argument("out", help="output directory")
    m_genpy.add_argument("types", nargs="+", help="message or service types")
    for p in (m_show, m_md5, m_list, m_genpy):
        p.add_argument("--msg-path", action="append", default=[], metavar="DIR")
        p.set_defaults(func=_cmd_msg)

    urdf = sub.add_parser("urdf", help="check a URDF or print its forward kinematics")
    usub = urdf.add_subparsers(dest="action", required=True)
    u_check = usub.add_parser("check", help="tree, joints, limits and warnings (like check_urdf)")
    u_fk = usub.add_parser("fk", help="world pose of every link")
    u_fk.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="JOINT=VALUE",
        help="joint value (radians or metres; repeatable)",
    )
    u_fk.add_argument("--json", action="store_true", help='{"link": {"xyz", "quat_xyzw"}}')
    u_fk.add_argument("--compact", action="store_true", help="one-line JSON")
    for p in (u_check, u_fk):
        p.add_argument("file", help="URDF or xacro file")
        p.add_argument(
            "--search-path",
            action="append",
            default=[],
            metavar="DIR",
            help="where package:// URIs are looked up (plus ROS_PACKAGE_PATH)",
        )
        p.set_defaults(func=_cmd_urdf)

    sim = sub.add_parser("sim", help="run a scene file headless (or in MuJoCo's viewer)")
    sim.add_argument("scene", help="scene YAML (see docs/scenes.md)")
    sim.add_argument(
        "--endpoint",
        type=_endpoint_address,
        default=None,
        metavar="HOST:PORT",
        help="serve the scene's ROS interfaces through this endpoint",
    )
    sim.add_argument("--duration", type=float, default=None, help="sim seconds (default: forever)")
    sim.add_argument(
        "--realtime",
        type=float,
        default=None,
        metavar="FACTOR",
        help="pace at FACTOR x real time (default: as fast as possible)",
    )
    sim.add_argument("--viewer", action="store_true", help="open MuJoCo's viewer (needs a display)")
    sim.set_defaults(func=_cmd_sim)

    demo = sub.add_parser("demo", help="run a demo end to end on the embedded backend")
    demo.add_argument(
        "name",
        nargs="?",
        default="pick-and-place",
        choices=["pick-and-place", "mobile-robot", "bridge"],
        help="pick-and-place (default): a Niryo One arm planned by a MoverService; "
        "mobile-robot: a diff-drive robot with lidar, camera, IMU and odometry drives a square; "
        "bridge: two connectors exchange Twist messages and a service call",
    )
    demo.add_argument(
        "--backend",
        choices=["local", "ros1"],
        default="local",
        help="pick-and-place: where the planner node runs",
    )
    demo.add_argument(
        "--json",
        action="store_true",
        help='pick-and-place: print {"success", "cube_error_m", "phases"} last',
    )
    demo.add_argument("--video", metavar="PATH", help="pick-and-place: write a .gif (or .mp4)")
    demo.add_argument("--seed", type=int, help="pick-and-place: random cube and target")
    demo.add_argument("--side", type=float, default=1.0, help="mobile-robot: square side (m)")
    demo.add_argument(
        "--realtime",
        type=float,
        default=0.0,
        help="mobile-robot: pace at this real-time factor (0 = flat out)",
    )
    demo.set_defaults(func=_cmd_demo)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the `simbridge` console script."""
    parser = build_parser()
    given = list(sys.argv[1:] if argv is None else argv)
    # roslaunch appends ROS arguments (__name:=x, _tcp_port:=10000): keep them for rospy.
    ros_args = tuple(arg for arg in given if ":=" in arg)
    args = parser.parse_args([arg for arg in given if ":=" not in arg])
    args.ros_args = ros_args
    quiet_tool = args.command in ("topic", "service", "msg", "urdf", "demo")
    level_name = args.log_level or ("WARNING" if quiet_tool else "INFO")
    logging.basicConfig(
        level=getattr(logging, str(level_name).upper(), logging.INFO),
        format="%(asctime)s %(levelname)s %(name)s: %(message)s",
    )
    try:
        return int(args.func(args))
    except SimbridgeError as exc:
        print(f"simbridge: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 130
    except BrokenPipeError:  # e.g. `simbridge urdf fk ... | head`
        sys.stderr.close()
        return 0


if __name__ == "__main__":
    sys.exit(main())
