"""Helpers shared by the subcommands: endpoint addresses, connecting, printing messages."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from simbridge.connector import Connector
    from simbridge.messages import MessageRegistry

__all__ = [
    "add_endpoint_arg",
    "connect",
    "endpoint_address",
    "print_msg",
    "reexec_in_ros2_venv",
]


def endpoint_address(text: str) -> tuple[str, int]:
    host, sep, port = text.rpartition(":")
    if not sep or not port.isdigit():
        raise argparse.ArgumentTypeError(
            f"--endpoint {text!r}: expected HOST:PORT, e.g. 127.0.0.1:10000"
        )
    return host or "127.0.0.1", int(port)


def add_endpoint_arg(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--endpoint",
        type=endpoint_address,
        default=("127.0.0.1", 10000),
        metavar="HOST:PORT",
        help="endpoint to connect to (default 127.0.0.1:10000)",
    )


def connect(args: argparse.Namespace) -> Connector:
    from simbridge.connector import Connector

    host, port = args.endpoint
    return Connector(host, port).connect(wait=args.connect_timeout)


def print_msg(registry: MessageRegistry, msg: object, no_arr: bool) -> None:
    import yaml

    data = registry.to_dict(msg)
    shown = strip_arrays(data) if no_arr else data
    print(yaml.safe_dump(shown, sort_keys=False, default_flow_style=None).rstrip())
    print("---", flush=True)


def strip_arrays(value: object) -> object:
    if isinstance(value, dict):
        return {k: strip_arrays(v) for k, v in value.items()}
    if isinstance(value, list | bytes) and len(value) > 8:
        return f"<array of {len(value)}>"
    if isinstance(value, list):
        return [strip_arrays(v) for v in value]
    return value


def reexec_in_ros2_venv() -> None:
    """rclpy lives in the ROS 2 venv (it cannot share an interpreter with rospy): run this
    same command with that venv's Python, without the ROS 1 paths (`--backend ros2` of
    the endpoint and the demos). Returns when rclpy is importable here already."""
    import importlib.util
    import os
    import sys

    if importlib.util.find_spec("rclpy") is not None:
        return
    from simbridge.endpoint.backends.ros2_env import ros2_python
    from simbridge.errors import EndpointError

    python = ros2_python()
    if python is None:
        raise EndpointError(
            "--backend ros2 needs the ROS 2 venv: run `make ros2` in the simbridge checkout, "
            "or set SIMBRIDGE_ROS2_PYTHON to a Python that has rclpy"
        )
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME")}
    argv = [str(python), "-m", "simbridge.cli", *sys.argv[1:]]
    sys.stdout.flush()
    sys.stderr.flush()
    os.execve(python, argv, env)
