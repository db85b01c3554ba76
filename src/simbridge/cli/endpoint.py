"""`simbridge endpoint`: the ROS-TCP server on the ROS side."""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import logging
import signal
from typing import TYPE_CHECKING

from .common import ensure_ros1, reexec_in_ros2_venv

if TYPE_CHECKING:
    from simbridge.endpoint import EndpointOptions
    from simbridge.endpoint.speed.busypoll import BusyPollSelector

__all__ = ["add_parser"]

_log = logging.getLogger("simbridge.endpoint")

DEFAULT_BUSY_POLL_US = 500.0
"""The ros1 backend's busy-poll limit: covers a rospy node's answer (~0.1-0.3 ms here)."""


def endpoint_options(
    args: argparse.Namespace, host: str | None, port: int | None
) -> EndpointOptions:
    """The server's options from the command line (`host` and `port` as resolved, None
    for the defaults)."""
    from simbridge.endpoint import EndpointOptions

    return EndpointOptions(
        host=host if host is not None else "127.0.0.1",
        port=port if port is not None else 10000,
        max_frame_size=int(args.max_frame_mb * 1024 * 1024),
        idle_timeout=args.idle_timeout,
        max_clients=args.max_clients,
        max_memory=int(args.max_memory_mb * 1024 * 1024),
        splice=not args.no_splice,
        drain_timeout=args.drain_timeout,
    )


def busy_poll_selector(args: argparse.Namespace) -> BusyPollSelector | None:
    """The endpoint loop's selector for `--busy-poll-us`, or None (asyncio's own) when off."""
    from simbridge.endpoint.speed.busypoll import BusyPollSelector

    limit_us = args.busy_poll_us
    if limit_us is None:  # on where it was measured to pay: rospy nodes answer in ~0.1 ms
        limit_us = DEFAULT_BUSY_POLL_US if args.backend == "ros1" else 0.0
    return BusyPollSelector(limit_us) if limit_us else None


def run_endpoint(args: argparse.Namespace) -> int:
    if args.backend == "ros1":
        ensure_ros1()
    if args.backend == "ros2":
        reexec_in_ros2_venv()
    from simbridge.endpoint import EndpointServer, make_backend

    selector = busy_poll_selector(args)
    backend = make_backend(
        args.backend,
        node_name=args.node_name,
        ros_args=args.ros_args,
        protocol=args.protocol,
        ros1_transport=args.ros1_transport,
    )
    if args.msg_path:
        from simbridge.messages import registry_for

        registry_for(backend.protocol).load_packages(*args.msg_path, lazy=True)
    if args.msg_path and args.backend == "ros2":
        # rclpy needs the interface packages built (once; unchanged ones are skipped).
        import importlib
        import sys
        from pathlib import Path

        from simbridge.endpoint.backends.ros2 import build_packages

        build_packages(args.msg_path, Path(sys.prefix), progress=print)
        importlib.invalidate_caches()

    async def run() -> None:
        # Precedence: command-line flag, then the original node's ~tcp_ip/~tcp_port, then default.
        host, port = args.host, args.port
        if args.backend == "ros1":
            from simbridge.endpoint.backends.ros1 import read_drop_in_params

            await backend.start()
            param_host, param_port = read_drop_in_params()
            host = host if host is not None else param_host
            port = port if port is not None else param_port
        options = endpoint_options(args, host, port)
        server = EndpointServer(options, backend)
        await server.start()
        print(
            f"simbridge endpoint listening on {options.host}:{server.port} "
            f"(backend {backend.name})",
            flush=True,
        )
        # SIGTERM (kill, systemd, roslaunch escalation) ends it as cleanly as SIGINT: every
        # registration is withdrawn from the ROS master before the process exits.
        stop = asyncio.Event()
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.add_signal_handler(sig, stop.set)
        serving = asyncio.ensure_future(server.serve_forever())
        stopping = asyncio.ensure_future(stop.wait())
        try:
            await asyncio.wait({serving, stopping}, return_when=asyncio.FIRST_COMPLETED)
        finally:
            stopping.cancel()
            serving.cancel()
            await server.close()
        if serving.done() and not serving.cancelled():
            serving.result()  # raises the EndpointError of a backend that left the graph

    with contextlib.suppress(KeyboardInterrupt):
        factory = None if selector is None else lambda: asyncio.SelectorEventLoop(selector)
        with asyncio.Runner(loop_factory=factory) as runner:
            runner.run(run())
    if selector is not None:
        _log.info(
            "busy poll: %d polls, %d spins found I/O, %d did not, %.3f s spinning",
            selector.polls,
            selector.hits,
            selector.misses,
            selector.spin_seconds,
        )
    return 0


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
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
    ep.add_argument(
        "--backend",
        choices=["local", "ros1", "ros2"],
        default="local",
        help="where topics and services go: local (an in-process bus, no ROS needed; the "
        "default), ros1 (a ROS 1 master) or ros2 (a ROS 2 graph)",
    )
    ep.add_argument("--node-name", default="/simbridge_endpoint", help="ROS node name (ros1, ros2)")
    ep.add_argument(
        "--ros1-transport",
        choices=["native", "rospy"],
        default="native",
        help="ros1 topic data path: the endpoint's own TCPROS on its loop, or rospy's threads",
    )
    ep.add_argument(
        "--protocol",
        type=str.upper,
        choices=["ROS1", "ROS2"],
        default=None,
        help="local backend: serialization clients are told to use (ROS2: CDR with ROS 2 "
        "layouts, to test a sim's ROS 2 path without ROS 2 installed; default ROS1)",
    )
    ep.add_argument(
        "--busy-poll-us",
        type=float,
        default=None,
        metavar="US",
        help="after handling I/O, poll up to this long (µs) before sleeping, while recent "
        f"waits show it pays: lower latency for CPU (0 = off; default {DEFAULT_BUSY_POLL_US:g} "
        "with --backend ros1, else 0; README: Latency)",
    )
    ep.add_argument(
        "--no-splice",
        action="store_true",
        help="copy large messages for a single ROS 1 subscriber through the endpoint instead "
        "of moving them between the sockets in the kernel (Linux splice)",
    )
    ep.add_argument("--max-frame-mb", type=float, default=64.0, help="largest accepted frame")
    ep.add_argument(
        "--max-clients", type=int, default=1000, help="connections served at once (default 1000)"
    )
    ep.add_argument(
        "--max-memory-mb",
        type=float,
        default=1024.0,
        help="memory all clients together may make the endpoint buffer: partial frames, "
        "queued messages and replies (default 1024; one client gets an eighth)",
    )
    ep.add_argument(
        "--idle-timeout",
        type=float,
        default=10.0,
        help="close clients silent this long (s); 0 disables",
    )
    ep.add_argument(
        "--drain-timeout",
        type=float,
        default=5.0,
        metavar="S",
        help="when a client leaves, how long each of its publishers may take to deliver what "
        "it accepted before it is closed (in the background; default 5)",
    )
    ep.add_argument(
        "--msg-path",
        action="append",
        default=[],
        metavar="DIR",
        help="directory of .msg/.srv/.action packages (repeatable)",
    )
    ep.set_defaults(func=run_endpoint)
