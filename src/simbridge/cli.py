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

from simbridge.errors import SimbridgeError

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

    backend = make_backend(args.backend, node_name=args.node_name)
    host, port = args.host, args.port
    options = EndpointOptions(
        host=host,
        port=port,
        max_frame_size=int(args.max_frame_mb * 1024 * 1024),
        idle_timeout=args.idle_timeout,
    )
    if args.msg_path:
        from simbridge.messages import default_registry

        default_registry().load_packages(*args.msg_path)
    server = EndpointServer(options, backend)

    async def run() -> None:
        await server.start()
        print(
            f"simbridge endpoint listening on {host}:{server.port} (backend {backend.name})",
            flush=True,
        )
        try:
            await server.serve_forever()
        finally:
            await server.close()

    with contextlib.suppress(KeyboardInterrupt):
        asyncio.run(run())
    return 0


def build_parser() -> argparse.ArgumentParser:
    """The full argument parser."""
    parser = argparse.ArgumentParser(prog="simbridge", description=__doc__)
    parser.add_argument("--log-level", default="INFO", help="DEBUG, INFO, WARNING or ERROR")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    ep = sub.add_parser("endpoint", help="run the ROS-TCP endpoint (TCP server on the ROS side)")
    ep.add_argument("--host", default="127.0.0.1", help="address to bind (default 127.0.0.1)")
    ep.add_argument("--port", type=int, default=10000, help="TCP port (default 10000; 0 = any)")
    ep.add_argument("--backend", choices=["local", "ros1"], default="local")
    ep.add_argument("--node-name", default="/simbridge_endpoint", help="ROS node name (ros1)")
    ep.add_argument("--max-frame-mb", type=float, default=64.0, help="largest accepted frame")
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
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the `simbridge` console script."""
    parser = build_parser()
    args = parser.parse_args(argv)
    logging.basicConfig(
        level=getattr(logging, str(args.log_level).upper(), logging.INFO),
        format="%(asctime)s %(levelname)s %(name)s: %(message)s",
    )
    try:
        return int(args.func(args))
    except SimbridgeError as exc:
        print(f"simbridge: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 130


if __name__ == "__main__":
    sys.exit(main())
