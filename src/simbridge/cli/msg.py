"""`simbridge msg`: inspect message types, md5sums and generate ROS 1 Python modules."""

from __future__ import annotations

import argparse

__all__ = ["add_parser"]


def run_build(args: argparse.Namespace) -> int:
    """Build interface packages into the ROS 2 venv (cached by content)."""
    from pathlib import Path

    from simbridge.endpoint.backends.ros2 import SHIPPED_ROS2_PACKAGES, build_packages, ros2_python
    from simbridge.errors import EndpointError
    from simbridge.messages.registry import SHIPPED_DEFINITIONS

    if args.venv:
        venv = Path(args.venv)
    else:
        python = ros2_python()
        if python is None:
            raise EndpointError("no ROS 2 venv: run `make ros2`, or pass --venv DIR")
        venv = python.parent.parent
    paths = [Path(p) for p in args.packages]
    if args.shipped:
        paths += [SHIPPED_DEFINITIONS / name for name in SHIPPED_ROS2_PACKAGES]
    if not paths:
        raise EndpointError("nothing to build: name package directories or pass --shipped")
    build_packages(
        paths, venv, force=args.force, progress=lambda line: print(f"simbridge msg build: {line}")
    )
    return 0


def run_msg(args: argparse.Namespace) -> int:
    from simbridge.messages import MessageRegistry, default_registry

    # Extra packages go into a private registry: the shared one stays as shipped.
    registry = MessageRegistry() if args.msg_path else default_registry()
    if args.msg_path:
        registry.load_packages(*args.msg_path)
    if args.action == "genpy":
        from pathlib import Path

        from .common import ensure_ros1

        ensure_ros1("msg genpy")  # genpy is ROS 1's, from Debian

        from simbridge.endpoint.backends.ros1 import generate_python_messages

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


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    msg = sub.add_parser("msg", help="inspect message types")
    msub = msg.add_subparsers(dest="action", required=True)
    m_show = msub.add_parser("show", help="fields of a message or service type")
    m_show.add_argument("type", help="message or service type, e.g. sensor_msgs/LaserScan")
    m_md5 = msub.add_parser("md5", help="genmsg md5sum of a type")
    m_md5.add_argument("type", help="message or service type, e.g. std_msgs/String")
    m_list = msub.add_parser("list", help="every known type")
    m_list.add_argument("--services", action="store_true", help="list service types instead")
    m_genpy = msub.add_parser(
        "genpy",
        help="generate ROS 1 Python modules (for rostopic/rosservice) for types Debian lacks",
    )
    m_genpy.add_argument("out", help="output directory")
    m_genpy.add_argument("types", nargs="+", help="message or service types")
    m_build = msub.add_parser(
        "build",
        help="build ROS 2 interface packages (msg/, srv/, action/) into the ROS 2 venv",
    )
    m_build.add_argument("packages", nargs="*", metavar="PKG_DIR", help="package directories")
    m_build.add_argument(
        "--shipped", action="store_true", help="also the shipped ones without a wheel"
    )
    m_build.add_argument("--venv", help="the ROS 2 venv (default: the checkout's .venv-ros2)")
    m_build.add_argument("--force", action="store_true", help="rebuild even when unchanged")
    m_build.set_defaults(func=run_build)
    for p in (m_show, m_md5, m_list, m_genpy):
        p.add_argument(
            "--msg-path",
            action="append",
            default=[],
            metavar="DIR",
            help="also load the .msg/.srv files of the package(s) in DIR (repeatable)",
        )
        p.set_defaults(func=run_msg)
