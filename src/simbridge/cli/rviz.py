"""`simbridge rviz DEMO|SCENE`: RViz (ROS 1) with the demo's or the scene's config."""

from __future__ import annotations

import argparse

__all__ = ["add_parser"]


def run_rviz(args: argparse.Namespace) -> int:
    import subprocess
    import tempfile
    from pathlib import Path

    from simbridge.apps.rviz import DEMOS, resolve_target, rviz_command, rviz_config

    if args.write is not None:
        Path(args.write).write_text(rviz_config(DEMOS.get(args.target, Path(args.target))))
        print(f"wrote {args.write}; start it with: rviz -d {args.write}")
        return 0
    with tempfile.TemporaryDirectory(prefix="simbridge-rviz-") as folder:
        target = resolve_target(args.target, Path(folder))
        command = rviz_command(target.config)
        print(f"simbridge: {' '.join(command)}", flush=True)
        return subprocess.run([*command, *args.ros_args], check=False).returncode


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    rviz = sub.add_parser(
        "rviz",
        help="start RViz (ROS 1) showing a demo or a scene run by `simbridge sim`",
        description="Start RViz with the robot model (from the robot_description parameter "
        "the sim sets), TF, lidar scans, point clouds, camera images and odometry. RViz "
        "joins the master in ROS_MASTER_URI and needs a display (DISPLAY).",
    )
    rviz.add_argument(
        "target",
        metavar="DEMO|SCENE",
        help="mobile-robot or pick-and-place (their shipped configs), or a scene .yaml",
    )
    rviz.add_argument(
        "--write",
        metavar="FILE",
        help="write the config to FILE (for `rviz -d FILE`) instead of starting rviz",
    )
    rviz.set_defaults(func=run_rviz)
