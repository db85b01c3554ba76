"""Simulator speed: physics steps per second and real-time factor for a 6-DoF arm scene.

The Niryo One (6 revolute joints and a mimic gripper) with its default position drives,
alone, following a trajectory, among dynamic boxes, publishing its ROS state (joint
states 50 Hz, TF 50 Hz, /clock 100 Hz) and paced at real time (which should land on a
factor of 1.0). The ROS state goes to an endpoint in its own process, as `simbridge sim
--endpoint` runs (the goal: >= 0.5 of the bare stepping speed), and for comparison to an
endpoint thread inside the simulator's process, whose work then shares the simulator's
interpreter lock.

Every scenario runs `REPEATS` (>= 3) times, in rounds that take each scenario in turn;
rows give the best and the median run and the 1-minute load average when the row's first
run started. `vs_bare`: steps/s over those of the bare trajectory run of the same round
(measured just before), best and median over the rounds.
"""

from __future__ import annotations

import contextlib
import os
import re
import signal
import subprocess
import sys
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # also as a bare script

from benchmarks.repeats import REPEATS, best_and_median, load_average
from simbridge.assets import robot_urdf
from simbridge.connector import Connector
from simbridge.endpoint import EndpointOptions, EndpointThread
from simbridge.sim.control import Trajectory
from simbridge.sim.ros import SimRosBridge
from simbridge.sim.scene import parse_scene
from simbridge.sim.world import World

__all__ = ["run"]

ARM_JOINTS = [f"joint_{i}" for i in range(1, 7)]


def _world(boxes: int = 0, timestep: float = 0.002) -> World:
    objects: list[dict[str, Any]] = [{"name": "floor", "type": "plane"}]
    objects += [
        {
            "name": f"box{i}",
            "type": "box",
            "size": [0.03, 0.03, 0.03],
            "dynamic": True,
            "mass": 0.05,
            "pose": {"xyz": [0.25 + 0.04 * (i % 5), -0.1 + 0.05 * (i // 5), 0.015]},
        }
        for i in range(boxes)
    ]
    scene = {
        "physics": {"timestep": timestep},
        "robots": [{"urdf": str(robot_urdf("niryo_one"))}],
        "objects": objects,
    }
    return World.from_scene(parse_scene(scene, robot_urdf("niryo_one").parent))


def _sweep(world: World) -> None:
    """Start a 4 s back-and-forth trajectory over all six arm joints."""
    out = [0.8, -0.6, 0.5, 1.0, -0.8, 1.2]
    traj = Trajectory.from_lists(ARM_JOINTS, [2.0, 4.0], [out, [0.0] * 6])
    world.follower.start(traj, world.time)


def _measure(
    world: World,
    sim_seconds: float,
    factor: float = 0.0,
    setup: Callable[[World], None] | None = None,
) -> dict[str, Any]:
    if setup is not None:
        setup(world)
    stats = world.run(duration=sim_seconds, realtime_factor=factor)
    return {
        "bodies": world.model.nbody,
        "dofs": world.model.nv,
        "timestep_ms": world.timestep * 1e3,
        "steps": stats.steps,
        "steps_per_s": stats.steps / stats.wall_time,
        "realtime_factor": stats.realtime_factor,
    }


def _with_ros(port: int, sim_seconds: float) -> dict[str, Any]:
    world = _world()
    connector = Connector("127.0.0.1", port).connect(wait=5)
    try:
        with SimRosBridge(world, connector):
            row = _measure(world, sim_seconds, setup=_sweep)
            connector.flush(5)
    finally:
        connector.close()
    return row


def _with_ros_in_process(sim_seconds: float) -> dict[str, Any]:
    with EndpointThread(EndpointOptions(port=0)) as endpoint:
        return _with_ros(endpoint.port, sim_seconds)


@contextlib.contextmanager
def _endpoint_process() -> Iterator[int]:
    """`simbridge endpoint` (local backend) in its own process; yields its port."""
    command = [sys.executable, "-m", "simbridge.cli", "--log-level", "WARNING", "endpoint"]
    proc = subprocess.Popen(
        [*command, "--port", "0", "--idle-timeout", "0"],
        stdout=subprocess.PIPE,
        text=True,
        start_new_session=True,
        env=dict(os.environ, PYTHONUNBUFFERED="1"),
    )
    try:
        assert proc.stdout is not None
        line = proc.stdout.readline()
        found = re.search(r"listening on \S+:(\d+)", line)
        if found is None:
            raise RuntimeError(f"the endpoint did not start: {line!r}")
        yield int(found[1])
    finally:
        os.killpg(proc.pid, signal.SIGINT)
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()


def run(sim_seconds: float = 20.0, repeats: int = REPEATS) -> list[dict[str, Any]]:
    """One row per scenario; `sim_seconds` of simulated time per run (real-time row: 2 s)."""
    with _endpoint_process() as port:
        scenarios: list[tuple[str, Callable[[], dict[str, Any]]]] = [
            ("arm holding pose", lambda: _measure(_world(), sim_seconds)),
            ("arm following a trajectory", lambda: _measure(_world(), sim_seconds, setup=_sweep)),
            (  # right after its bare twin: the ratio of one moment
                "arm + ROS state, endpoint process",
                lambda: _with_ros(port, sim_seconds),
            ),
            (
                "arm + ROS state, in-process endpoint thread",
                lambda: _with_ros_in_process(sim_seconds),
            ),
            (
                "arm + 20 dynamic boxes",
                lambda: _measure(_world(boxes=20), sim_seconds, setup=_sweep),
            ),
            (
                "arm, 1 ms timestep",
                lambda: _measure(_world(timestep=0.001), sim_seconds, setup=_sweep),
            ),
            (
                "arm paced at real time",
                lambda: _measure(_world(), 2.0, factor=1.0, setup=_sweep),
            ),
        ]
        runs: dict[str, list[dict[str, Any]]] = {name: [] for name, _ in scenarios}
        loads: dict[str, float] = {}
        for _ in range(repeats):
            for name, measure in scenarios:
                loads.setdefault(name, load_average())
                runs[name].append(measure())
    bare = [r["steps_per_s"] for r in runs["arm following a trajectory"]]
    rows = []
    for name, results in runs.items():
        first = results[0]
        best, median = best_and_median([r["steps_per_s"] for r in results])
        row: dict[str, Any] = {
            "scenario": name,
            "bodies": first["bodies"],
            "dofs": first["dofs"],
            "timestep_ms": first["timestep_ms"],
            "load_1min": loads[name],
            "steps_per_s_best": best,
            "steps_per_s_median": median,
            "realtime_factor_median": best_and_median([r["realtime_factor"] for r in results])[1],
            "vs_bare_best": "",
            "vs_bare_median": "",
        }
        if name != "arm paced at real time":
            ratios = [r["steps_per_s"] / b for r, b in zip(results, bare, strict=True)]
            row["vs_bare_best"], row["vs_bare_median"] = best_and_median(ratios)
        rows.append(row)
    return rows


if __name__ == "__main__":
    from benchmarks.table import format_table
    from benchmarks.usage import exit_on_help

    exit_on_help(__doc__, "  --markdown  a Markdown table")

    print(format_table(run(), markdown="--markdown" in sys.argv))
