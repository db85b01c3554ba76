"""Who drives the line's robots: in-process nodes on the endpoint's bus (local, ROS 1), or a
ROS 2 process of their own (`ros2_cells`), started here and read back as JSON; either way the
same `LineSupervisor`, and the same `Drive` summary for the result."""

from __future__ import annotations

import functools
import json
import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from contextlib import ExitStack
from dataclasses import dataclass, field
from typing import Any

from simbridge.apps.line.cells import ArmCell, ConveyorCell, NodeGraph, RobotNode
from simbridge.apps.line.scene import ARMS, CONVEYOR
from simbridge.apps.line.supervisor import LineSupervisor
from simbridge.apps.line.task import LineTask
from simbridge.endpoint import Backend, Node
from simbridge.errors import AppError, SimbridgeError

__all__ = ["Drive", "drive_in_process", "drive_ros2", "set_paused"]

_CELLS_MODULE = "simbridge.apps.line.ros2_cells"
_RESULT_KEY = "line_cells"
"""`ros2_cells.RESULT_KEY` (that module imports rclpy; this one must not)."""


@dataclass
class Drive:
    """What the robots' side of a run reports: the supervisor's times (sim s), its planning
    time (wall s), each robot's tally, and the failed step, if any."""

    first_goal_at: float | None = None
    last_delivery_at: float | None = None
    planning_wall_s: float = 0.0
    robots: dict[str, dict[str, Any]] = field(default_factory=dict)
    error: str | None = None


def set_paused(node: Node, service: str, paused: bool) -> None:
    """Pause (True) or resume the simulation through its std_srvs/SetBool `service`."""
    registry = node.registry
    request = registry.new(registry.service("std_srvs/SetBool").request, data=paused)
    response: Any = node.call(service, "std_srvs/SetBool", request, timeout=10)
    if not response.success:
        raise AppError(f"{service} refused data={paused}: {response.message}")


def drive_in_process(
    stack: ExitStack,
    bus: Backend,
    loop: Any,
    task: LineTask,
    *,
    pause_service: str,
    sim_time: Callable[[], float],
    alive: Callable[[], bool],
    say: Callable[[str], None],
    seed: int,
) -> Drive:
    """One node per robot and the supervisor's on the endpoint's bus (closed by `stack`)."""

    def graph(robot: str) -> NodeGraph:
        return NodeGraph(bus, f"/{robot}_cell", loop=loop)

    arm_in = ArmCell(graph(ARMS[0]), f"/{ARMS[0]}", alive=alive)
    arm_out = ArmCell(graph(ARMS[1]), f"/{ARMS[1]}", alive=alive)
    conveyor = ConveyorCell(graph(CONVEYOR), f"/{CONVEYOR}", alive=alive)
    cells: dict[str, RobotNode] = {ARMS[0]: arm_in, ARMS[1]: arm_out, CONVEYOR: conveyor}
    for cell in cells.values():
        stack.callback(cell.close)
    node = Node(bus, "/line_supervisor", loop=loop)
    stack.callback(node.close)
    for cell in cells.values():
        cell.wait_ready(10.0)
    supervisor = LineSupervisor(
        task, arm_in, arm_out, conveyor, functools.partial(set_paused, node, pause_service),
        sim_time=sim_time, progress=say, seed=seed,
    )  # fmt: skip
    drive = Drive()
    try:
        supervisor.run()
    except SimbridgeError as exc:
        drive.error = str(exc)
    drive.first_goal_at = supervisor.first_goal_at
    drive.last_delivery_at = supervisor.last_delivery_at
    drive.planning_wall_s = supervisor.planning_wall_s
    drive.robots = {name: cell.tally().to_dict() for name, cell in cells.items()}
    return drive


def drive_ros2(
    task: LineTask,
    seed: int,
    *,
    pause_service: str,
    alive: Callable[[], bool],
    say: Callable[[str], None],
    on_summary: Callable[[], object] = lambda: None,
    timeout_s: float = 1800.0,
) -> Drive:
    """Run `ros2_cells` in a process of its own (this Python: the ROS 2 venv's, with the
    ROS 2 settings the endpoint put in the environment), forward its progress lines to `say`
    and return its summary (`on_summary` runs as it arrives, before the process has left
    ROS 2); AppError when it ends without one. It is stopped if the simulation stops first or
    after `timeout_s`."""
    command = [
        sys.executable, "-m", _CELLS_MODULE, "--seed", str(seed),
        "--parts", str(len(task.parts)), "--pause", pause_service,
    ]  # fmt: skip
    proc = subprocess.Popen(
        command,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
        start_new_session=True,
    )
    summary: dict[str, Any] = {}
    tail: list[str] = []

    def read() -> None:
        assert proc.stdout is not None
        for line in proc.stdout:
            text = line.rstrip("\n")
            if text.startswith("{") and _RESULT_KEY in text:
                summary.update(json.loads(text)[_RESULT_KEY])
                on_summary()
            elif text:
                tail.append(text)
                del tail[:-20]
                say(text)

    reader = threading.Thread(target=read, name="line-ros2-cells", daemon=True)
    reader.start()
    deadline = time.monotonic() + timeout_s
    try:
        while proc.poll() is None:
            if not alive() or time.monotonic() > deadline:
                break
            time.sleep(0.05)
    finally:
        _stop(proc)
        reader.join(10)
    if not summary:
        raise AppError(
            f"the ROS 2 cells process ended ({proc.returncode}) without its summary; "
            "its last lines:\n" + "\n".join(tail)
        )
    return Drive(
        first_goal_at=summary["first_goal_at"],
        last_delivery_at=summary["last_delivery_at"],
        planning_wall_s=float(summary["planning_wall_s"]),
        robots=summary["robots"],
        error=summary["error"],
    )


def _stop(proc: subprocess.Popen[str]) -> None:
    """SIGINT (a clean rclpy shutdown frees Fast DDS's shared memory), then SIGKILL."""
    if proc.poll() is not None:
        return
    try:
        os.killpg(proc.pid, signal.SIGINT)
        proc.wait(10)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(10)
    except ProcessLookupError:
        pass
