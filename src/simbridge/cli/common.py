"""Helpers shared by the subcommands: endpoint addresses, connecting, printing messages."""

from __future__ import annotations

import argparse
import importlib
import importlib.util
import sys
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from simbridge.connector import Connector
    from simbridge.messages import MessageRegistry

__all__ = [
    "DEBIAN_DIST_PACKAGES",
    "add_endpoint_arg",
    "connect",
    "endpoint_address",
    "ensure_ros1",
    "print_msg",
    "reexec_in_ros2_venv",
]

DEBIAN_DIST_PACKAGES = Path("/usr/lib/python3/dist-packages")
"""Where Debian's ROS 1 Python packages (python3-rospy and friends) are installed."""


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
    from simbridge.endpoint.backends.ros2 import ros2_python
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


def ensure_ros1(what: str = "--backend ros1", folder: Path = DEBIAN_DIST_PACKAGES) -> None:
    """ROS 1's Python packages (rospy, rosgraph, genpy) come from Debian, not PyPI: when this
    Python lacks them and Debian's `folder` has them, append it to sys.path (after this
    environment's own packages, as the checkout's venv does with a .pth file); otherwise
    EndpointError saying what to install. Returns once `rospy` imports."""
    from simbridge.errors import EndpointError

    if _has_rospy():
        return
    install = (
        "install ROS 1 from Debian (Debian 12 or later): `sudo apt install ros-core "
        "python3-rospy python3-rostopic python3-rosservice python3-genpy` (the simbridge "
        "checkout's scripts/install-system-deps.sh lists every package it uses); or use "
        "--backend local (no ROS needed) or ros2"
    )
    if not (folder / "rospy").is_dir():
        raise EndpointError(
            f"{what} needs rospy, which neither this Python nor {folder} has: {install}"
        )
    if str(folder) not in sys.path:
        sys.path.append(str(folder))
        importlib.invalidate_caches()
    try:
        importlib.import_module("rospy")
    except ImportError as exc:
        version = f"{sys.version_info.major}.{sys.version_info.minor}"
        raise EndpointError(
            f"{what}: Debian's ROS 1 in {folder} does not import into this Python {version} "
            f"({exc}); use a Python of the same minor version as /usr/bin/python3, or {install}"
        ) from None


def _has_rospy() -> bool:
    return importlib.util.find_spec("rospy") is not None
