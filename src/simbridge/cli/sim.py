"""`simbridge urdf` and `simbridge sim`: robot descriptions and scenes."""

from __future__ import annotations

import argparse
import contextlib
import signal
import sys
import threading
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, TextIO

from .common import endpoint_address

if TYPE_CHECKING:
    from simbridge.apps.ros2_node import Ros2SimNode

__all__ = ["SHIPPED_SCENES", "add_parser", "scene_file"]

SHIPPED_SCENES = {
    "mobile-robot": ("apps", "mobile_robot", "scene.yaml"),
    "pick-and-place": ("apps", "pick_and_place", "scene.yaml"),
    "line": ("apps", "line", "scene.yaml"),
    "reach": ("gym", "scenes", "reach.yaml"),
}
"""Scenes shipped inside the package, by the name `simbridge sim NAME` takes."""


def scene_file(text: str) -> Path:
    """The scene `simbridge sim` was given: a file, else a shipped scene's name. Neither:
    SimError naming the shipped scenes (and the closest one)."""
    from importlib import resources

    from simbridge.errors import SimError, did_you_mean

    given = Path(text)
    if given.exists() or text not in SHIPPED_SCENES:
        if given.exists() or given.suffix in (".yaml", ".yml") or "/" in text:
            return given  # a file: loading it says what is wrong with it
        raise SimError(
            f"no scene file or shipped scene '{text}'{did_you_mean(text, SHIPPED_SCENES)} "
            f"(shipped: {', '.join(SHIPPED_SCENES)}; or a path to a scene YAML file)"
        )
    return Path(str(resources.files("simbridge").joinpath(*SHIPPED_SCENES[text])))


class _SceneFormat(argparse.Action):
    """`--scene-format`: print the scene file reference (docs/scenes.md, shipped in the
    package as simbridge/assets/scenes.md) and exit, as --version does."""

    def __init__(self, option_strings: list[str], dest: str, help: str | None = None) -> None:
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS, help=help)

    def __call__(
        self,
        parser: argparse.ArgumentParser,
        namespace: argparse.Namespace,
        values: object,
        option_string: str | None = None,
    ) -> None:
        from simbridge.assets import asset_path

        sys.stdout.write(asset_path("scenes.md").read_text())
        parser.exit()


@contextmanager
def _plain_warnings(show: bool = True) -> Iterator[None]:
    """Print simbridge's load warnings as `simbridge: warning: ...` (or not at all)."""
    from simbridge.sim.urdf import UrdfWarning

    def show_warning(  # noqa: PLR0917 (the signature warnings.showwarning has)
        message: Warning | str,
        category: type[Warning],
        filename: str,
        lineno: int,
        file: TextIO | None = None,
        line: str | None = None,
    ) -> None:
        if issubclass(category, UrdfWarning):
            if show:
                print(f"simbridge: warning: {message}", file=sys.stderr)
            return
        original(message, category, filename, lineno, file, line)

    with warnings.catch_warnings():
        warnings.simplefilter("always", UrdfWarning)
        original = warnings.showwarning
        warnings.showwarning = show_warning
        yield


@contextmanager
def _sigterm_interrupts() -> Iterator[None]:
    """SIGTERM (kill, systemd, a launch file's shutdown) stops the run as Ctrl-C does: the
    recording is closed, registrations withdrawn and what ran is reported. SIGINT gets the
    same handler explicitly: a process started with SIGINT ignored (inherited from a parent
    that ignores it) would otherwise never see Ctrl-C."""

    def interrupt(_sig: int, _frame: object) -> None:
        raise KeyboardInterrupt

    if threading.current_thread() is not threading.main_thread():  # signals reach only it
        yield
        return
    previous = {sig: signal.signal(sig, interrupt) for sig in (signal.SIGTERM, signal.SIGINT)}
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


def _xacro_args(args: argparse.Namespace) -> dict[str, str]:
    """`NAME:=VALUE` words (set aside by the top-level parser) and `--arg NAME=VALUE`."""
    from simbridge.sim.urdf import parse_xacro_args

    return parse_xacro_args([*getattr(args, "ros_args", ()), *args.arg])


def run_urdf(args: argparse.Namespace) -> int:
    import json

    from simbridge.sim.urdf import urdf_check, urdf_fk

    xacro_args = _xacro_args(args)
    if args.action == "check":
        with _plain_warnings(show=False):  # the report lists them
            report = urdf_check(args.file, args.search_path, xacro_args, args.strict)
        print(report.rstrip())
        return 0
    with _plain_warnings():
        poses = urdf_fk(args.file, args.set, args.search_path, xacro_args, args.strict)
    if args.json:
        print(json.dumps(poses, indent=None if args.compact else 2))
    else:
        width = max((len(link) for link in poses), default=0)
        for link, pose in poses.items():
            xyz = " ".join(f"{v: .6f}" for v in pose["xyz"])
            quat = " ".join(f"{v: .6f}" for v in pose["quat_xyzw"])
            print(f"{link:<{width}}  xyz [{xyz}]  quat_xyzw [{quat}]")
    return 0


def run_sim(args: argparse.Namespace) -> int:
    from simbridge.errors import ConnectorError
    from simbridge.sim.record import RecordOptions
    from simbridge.sim.runner import run_scene
    from simbridge.sim.scene import load_scene, with_overrides
    from simbridge.sim.view import ViewOptions

    node = _ros2_node(args)  # before the scene loads: a wrong interpreter fails at once
    scene = with_overrides(
        load_scene(scene_file(args.scene)), _xacro_args(args), strict=args.strict
    )
    endpoint = f"{args.endpoint[0]}:{args.endpoint[1]}" if args.endpoint else None
    record = RecordOptions(Path(args.record), args.record_buffer) if args.record else None
    view = None
    realtime = args.realtime
    if args.view:  # a view shows the run as it happens, and stays up after it
        follow = args.view_follow
        view = ViewOptions(args.view_host, args.view_port, args.view_rate, follow, linger=True)
        realtime = 1.0 if realtime is None else realtime
    with _plain_warnings(), _sigterm_interrupts(), node or contextlib.nullcontext():
        try:
            stats = run_scene(
                scene,
                endpoint=endpoint,
                duration=args.duration,
                realtime_factor=realtime,
                viewer=args.viewer,
                record=record,
                view=view,
                connect_timeout=None if args.wait_for_endpoint else args.connect_timeout,
                progress=True,
                connect=node.connector if node is not None else None,
            )
        except ConnectorError as exc:
            raise ConnectorError(
                f"{exc}: start one first (`simbridge endpoint`), or pass --wait-for-endpoint "
                "to simulate at once and keep trying"
            ) from None
    print(
        f"simulated {stats.sim_time:.3f} s in {stats.wall_time:.3f} s wall "
        f"({stats.steps} steps, {stats.realtime_factor:.2f}x real time)"
    )
    return 0


def _ros2_node(args: argparse.Namespace) -> Ros2SimNode | None:
    """With --ros2, the sim's own ROS 2 node (not started; AppError without rclpy)."""
    if not args.ros2:
        return None
    from simbridge.apps.ros2_node import Ros2SimNode, require_rclpy
    from simbridge.errors import AppError

    if args.endpoint:
        raise AppError("give --endpoint HOST:PORT or --ros2, not both")
    require_rclpy()
    return Ros2SimNode(args.node_name)


def _load_options(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--arg",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="xacro argument (repeatable); NAME:=VALUE after the file works too",
    )
    p.add_argument(
        "--strict",
        action="store_true",
        help="refuse tolerated defects (duplicate definitions, reused joint names, "
        "out-of-range initial positions)",
    )


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    urdf = sub.add_parser("urdf", help="check a URDF or print its forward kinematics")
    usub = urdf.add_subparsers(dest="action", required=True)
    u_check = usub.add_parser(
        "check", help="tree, joints, limits and warnings (like check_urdf); loads every mesh"
    )
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
        p.add_argument("file", help="URDF or xacro file (then NAME:=VALUE xacro args)")
        p.add_argument(
            "--search-path",
            action="append",
            default=[],
            metavar="DIR",
            help="where package:// URIs are looked up (plus ROS_PACKAGE_PATH)",
        )
        _load_options(p)
        p.set_defaults(func=run_urdf)

    sim = sub.add_parser("sim", help="run a scene file headless (or in MuJoCo's viewer)")
    sim.add_argument(
        "scene",
        help=f"a scene YAML file, or a shipped scene: {', '.join(SHIPPED_SCENES)} (the format: "
        "simbridge sim --scene-format); then NAME:=VALUE xacro args",
    )
    sim.add_argument(
        "--scene-format",
        action=_SceneFormat,
        help="print the scene file reference shipped with simbridge (every section and key, "
        "with examples; the documentation's Scene files page) and exit",
    )
    sim.add_argument(
        "--endpoint",
        type=endpoint_address,
        default=None,
        metavar="HOST:PORT",
        help="serve the scene's ROS interfaces through this endpoint",
    )
    sim.add_argument(
        "--ros2",
        action="store_true",
        help="serve the scene's ROS interfaces as a ROS 2 node of this process (rclpy: run "
        "with .venv-ros2/bin/simbridge, `make ros2`), without an endpoint",
    )
    sim.add_argument(
        "--node-name",
        default="simbridge_sim",
        metavar="NAME",
        help="with --ros2: the node's name (default simbridge_sim)",
    )
    sim.add_argument(
        "--connect-timeout",
        type=float,
        default=10.0,
        metavar="SECONDS",
        help="with --endpoint: fail (exit 2) when no endpoint answers within SECONDS (default 10)",
    )
    sim.add_argument(
        "--wait-for-endpoint",
        action="store_true",
        help="with --endpoint: start simulating at once and keep trying to connect until "
        "an endpoint answers, instead of failing after --connect-timeout",
    )
    sim.add_argument("--duration", type=float, default=None, help="sim seconds (default: forever)")
    sim.add_argument(
        "--realtime",
        type=float,
        default=None,
        metavar="FACTOR",
        help="pace at FACTOR x real time, 0 = as fast as possible (default: 1 with "
        "--endpoint or --view, whatever the scene says, so ROS nodes, commands and the eye "
        "see real time; otherwise the scene's physics.realtime_factor, 1 unless set)",
    )
    sim.add_argument("--viewer", action="store_true", help="open MuJoCo's viewer (needs a display)")
    sim.add_argument(
        "--record",
        metavar="FILE",
        default=None,
        help="record every topic in and out (sim-time stamps) to FILE: .mcap (rosbag2 "
        "MCAP) or .bag (ROS 1); needs --endpoint or --ros2",
    )
    sim.add_argument(
        "--record-buffer",
        type=int,
        default=10000,
        metavar="N",
        help="messages waiting to be written before new ones are dropped (default 10000)",
    )
    sim.add_argument(
        "--view",
        action="store_true",
        help="serve a live 3D view in the browser (viser) at http://127.0.0.1:8080, in real "
        "time unless --realtime says otherwise; it stays up after --duration until Ctrl-C",
    )
    sim.add_argument(
        "--view-follow",
        default=None,
        metavar="NAME",
        help="what the view's camera follows: a robot or body by name, or 'nothing' "
        "(default: the first robot; the page's Follow menu changes it)",
    )
    sim.add_argument(
        "--view-port",
        type=int,
        default=8080,
        help="live view port (default 8080; taken is an error; 0: any free port)",
    )
    sim.add_argument(
        "--view-host",
        default="127.0.0.1",
        help="live view address (default loopback; 0.0.0.0 serves the network)",
    )
    sim.add_argument(
        "--view-rate", type=float, default=30.0, help="pose updates per second (default 30)"
    )
    _load_options(sim)
    sim.set_defaults(func=run_sim)
