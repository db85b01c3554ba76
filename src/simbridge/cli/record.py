"""`simbridge play`: replay a recording (`simbridge sim --record`) into a ROS graph."""

from __future__ import annotations

import argparse
from pathlib import Path

from .common import add_endpoint_arg

__all__ = ["add_parser"]


def run_play(args: argparse.Namespace) -> int:
    from simbridge.connector import Connector
    from simbridge.errors import SimError
    from simbridge.sim.record import PlayOptions, bag_kind, play

    bag_kind(args.file)
    if not Path(args.file).is_file():
        raise SimError(f"recording '{args.file}' does not exist")
    host, port = args.endpoint
    connector = Connector(host, port)
    try:
        connector.connect(wait=args.connect_timeout)
        if not connector.connected:
            raise SimError(f"no endpoint answered at {host}:{port}")
        options = PlayOptions(rate=args.rate, loop=args.loop, clock=not args.no_clock)
        try:
            stats = play(args.file, connector, options)
        except KeyboardInterrupt:
            return 0
        connector.flush(5.0)
    finally:
        connector.close()
    print(
        f"played {stats.sent} messages on {len(stats.topics)} topics "
        f"({stats.failed} not convertible, {stats.loops} pass(es))"
    )
    return 0


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("play", help="replay a .mcap or .bag recording into a graph, with /clock")
    p.add_argument("file", help="recording from `simbridge sim --record` (.mcap or .bag)")
    add_endpoint_arg(p)
    p.add_argument(
        "--rate", type=float, default=1.0, help="speed factor (default 1; 0 = as fast as possible)"
    )
    p.add_argument("--loop", action="store_true", help="start again at the end (Ctrl-C stops)")
    p.add_argument(
        "--no-clock", action="store_true", help="do not publish /clock from the recorded stamps"
    )
    p.add_argument(
        "--connect-timeout", type=float, default=5.0, help="seconds to wait for the endpoint"
    )
    p.set_defaults(func=run_play)
