"""`simbridge urdf` and `simbridge sim`: robot descriptions and scenes."""

from __future__ import annotations

import argparse

from .common import endpoint_address

__all__ = ["add_parser"]


def run_urdf(args: argparse.Namespace) -> int:
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


def run_sim(args: argparse.Namespace) -> int:
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


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
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
        p.set_defaults(func=run_urdf)

    sim = sub.add_parser("sim", help="run a scene file headless (or in MuJoCo's viewer)")
    sim.add_argument("scene", help="scene YAML (see docs/scenes.md)")
    sim.add_argument(
        "--endpoint",
        type=endpoint_address,
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
    sim.set_defaults(func=run_sim)
