"""The `simbridge` command line: endpoint, topic/service tools, messages, URDF, sim, demos,
training.

One module per group of subcommands; their implementations import lazily so
`simbridge msg md5` stays quick.
"""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Sequence

from simbridge import __version__
from simbridge.errors import SimbridgeError

from . import datagen, demo, endpoint, graph, msg, planner, record, rviz, sim, train

__all__ = ["build_parser", "main"]

log = logging.getLogger("simbridge")

_GROUPS = (endpoint, graph, msg, sim, datagen, demo, planner, record, rviz, train)


def build_parser() -> argparse.ArgumentParser:
    """The full argument parser."""
    parser = argparse.ArgumentParser(prog="simbridge", description=__doc__)
    parser.add_argument(
        "--version", action="version", version=f"simbridge {__version__}", help="print the version"
    )
    parser.add_argument(
        "--log-level",
        default=None,
        help="DEBUG, INFO, WARNING or ERROR (default INFO for servers, WARNING for tools); "
        "other libraries log only warnings unless DEBUG",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for group in _GROUPS:
        group.add_parser(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the `simbridge` console script."""
    parser = build_parser()
    given = list(sys.argv[1:] if argv is None else argv)
    # ROS 2 style: everything after --ros-args is for rcl.
    rcl_args: tuple[str, ...] = ()
    if "--ros-args" in given:
        cut = given.index("--ros-args")
        given, rcl_args = given[:cut], tuple(given[cut:])
    # roslaunch appends ROS arguments (__name:=x, _tcp_port:=10000): keep them for rospy.
    ros_args = tuple(arg for arg in given if ":=" in arg) + rcl_args
    args = parser.parse_args(demo.with_default_demo(arg for arg in given if ":=" not in arg))
    args.ros_args = ros_args
    quiet_tool = args.command in ("topic", "service", "msg", "urdf", "demo", "datagen")
    level_name = args.log_level or ("WARNING" if quiet_tool else "INFO")
    level = getattr(logging, str(level_name).upper(), logging.INFO)
    if not logging.getLogger().handlers:  # a host (a test runner) may have set logging up
        # Libraries' INFO lines (PyOpenGL's "No OpenGL_accelerate module loaded", rospy's)
        # are not news to a user: they log warnings and errors only, unless DEBUG is asked.
        logging.basicConfig(
            level=level if level <= logging.DEBUG else max(level, logging.WARNING),
            format="%(asctime)s %(levelname)s %(name)s: %(message)s",
        )
        logging.getLogger("simbridge").setLevel(level)
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
