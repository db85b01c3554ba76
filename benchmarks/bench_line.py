"""The line demo over 20 seeds, and its real-time factor beside a single arm's.

Run: `python -m benchmarks.bench_line [--markdown]`. `run()` returns two tables:
- delivery: one row per seed (3 parts each; delivered within 2 cm, worst error, time per
  part, real-time factor of the whole run with its planning pauses), then a summary row;
- real-time factor: the line scene (two arms and the conveyor) and a single arm (arm_in of
  the same scene alone, the pick-and-place arm with the same ROS interfaces) run flat out
  for the same sim time with every robot's joint states, /tf, /clock and controller state
  and action feedback (a goal running on every controller) published to subscribers on
  the local bus; and the pick-and-place demo itself (no ROS traffic while it executes).
`rtf` is sim seconds per wall second; `rtf_cpu` per CPU second of the whole process, which
says what a busy machine hides (on an idle one the two agree, or rtf is higher when
threads run in parallel).
"""

from __future__ import annotations

import dataclasses
import statistics
import threading
import time
from typing import Any

import numpy as np

from benchmarks.line_table import PARTS, SEEDS, delivery_row, summary_row
from simbridge.apps.line import ARMS, CONVEYOR, SCENE_PATH, LineTask, line_scene, run_line
from simbridge.apps.line.cells import FOLLOW
from simbridge.apps.line.scene import grasp_contacts
from simbridge.apps.pick_and_place import run_pick_and_place
from simbridge.connector import ConnectorOptions
from simbridge.endpoint import EndpointOptions, EndpointThread, LocalBus, Node, NodeActionClient
from simbridge.planning import JointTrajectory, robot_trajectory_message
from simbridge.sim.runner import SimulationSession

__all__ = ["SEEDS", "run", "scene_rtf"]

STEADY_SIM_S = 20.0
_SWEEPS = {  # robot -> (controller, joints, amplitude of a slow sweep)
    "arm_in": ("arm_controller", tuple(f"joint_{i}" for i in range(1, 7)), 0.4),
    "arm_out": ("arm_controller", tuple(f"joint_{i}" for i in range(1, 7)), 0.4),
    CONVEYOR: ("pallet_controller", ("pallet_joint",), -0.15),
}


def _sweep(joints: tuple[str, ...], amplitude: float, duration: float) -> JointTrajectory:
    times = np.linspace(0.0, duration, 41)
    shape = amplitude * np.sin(np.pi * times / duration) ** 2
    positions = np.repeat(shape[:, None], len(joints), axis=1)
    positions[:, 1:] *= 0.5  # the shoulder and below move less
    if len(joints) == 1:
        positions = shape[:, None]
    rates = np.gradient(positions, times, axis=0)
    return JointTrajectory(joints, times, positions, rates, np.zeros_like(positions))


def scene_rtf(robots: tuple[str, ...], sim_s: float = STEADY_SIM_S) -> dict[str, Any]:
    """Run the line scene with only ``robots`` flat out for ``sim_s`` with a goal on every
    controller and subscribers on everything; sim seconds per wall second and counts."""
    task = LineTask.random(0, 1)
    scene = line_scene(task, SCENE_PATH)
    scene = dataclasses.replace(scene, robots=tuple(r for r in scene.robots if r.name in robots))
    extensions = grasp_contacts(task, arms=tuple(a for a in ARMS if a in robots))
    counts: dict[str, int] = {}
    lock = threading.Lock()

    def counter(topic: str) -> Any:
        def count(_msg: Any) -> None:
            with lock:
                counts[topic] = counts.get(topic, 0) + 1

        return count

    bus = LocalBus()
    with (
        EndpointThread(EndpointOptions(port=0), bus) as endpoint,
        SimulationSession(
            scene,
            f"127.0.0.1:{endpoint.port}",
            ConnectorOptions(reconnect_initial=0.2),
            connect_timeout=5.0,
            extensions=extensions,
        ) as session,
        Node(bus, "/bench") as node,
    ):
        world = session.world
        node.subscribe("/tf", "tf2_msgs/TFMessage", counter("/tf"))
        node.subscribe("/clock", "rosgraph_msgs/Clock", counter("/clock"))
        goals = []
        for robot in robots:
            controller, joints, amplitude = _SWEEPS[robot]
            node.subscribe(f"/{robot}/joint_states", "sensor_msgs/JointState", counter(robot))
            node.subscribe(
                f"/{robot}/{controller}/state",
                "control_msgs/JointTrajectoryControllerState",
                counter(f"{robot} state"),
            )
            client = NodeActionClient(
                node, f"/{robot}/{controller}/follow_joint_trajectory", FOLLOW
            )
            goals.append((client, robot, _sweep(joints, amplitude, sim_s)))
        warmup = threading.Thread(target=world.run, args=(None, 0.0))
        warmup.start()
        for client, robot, _trajectory in goals:
            if not client.wait_for_server(10):
                raise RuntimeError(f"no action server for {robot}")
        world.stop()
        warmup.join()
        for client, robot, trajectory in goals:
            goal = node.registry.new(f"{FOLLOW}Goal")
            goal.trajectory = robot_trajectory_message(trajectory, node.registry).joint_trajectory
            client.send_goal(goal, on_feedback=counter(f"{robot} feedback"))
        time.sleep(0.2)
        with lock:
            counts.clear()
        start_sim, began, cpu = world.time, time.perf_counter(), time.process_time()
        world.run(sim_s, 0.0)
        wall = time.perf_counter() - began
        cpu = time.process_time() - cpu
        time.sleep(0.3)
    with lock:
        per_s = {k: round(v / sim_s, 1) for k, v in sorted(counts.items())}
    simulated = world.time - start_sim
    return {
        "sim_s": round(simulated, 2),
        "wall_s": round(wall, 2),
        "rtf": round(simulated / wall, 1),
        "rtf_cpu": round(simulated / cpu, 1),
        "per_sim_s": per_s,
    }


def _delivery(seeds: tuple[int, ...]) -> list[dict[str, Any]]:
    rows = [delivery_row(seed, run_line(seed, PARTS, progress=None).to_dict()) for seed in seeds]
    return [*rows, summary_row(rows, PARTS)]


def _pick_and_place_rtf(seeds: tuple[int, ...] = (0, 1, 2)) -> tuple[float, float]:
    """Sim seconds per wall and per CPU second of pick-and-place runs (planning included,
    as the line's figures include theirs)."""
    sim = wall = cpu = 0.0
    for seed in seeds:
        began, cpu_began = time.perf_counter(), time.process_time()
        result = run_pick_and_place("local", seed=seed, progress=None)
        wall += time.perf_counter() - began
        cpu += time.process_time() - cpu_began
        sim += sum(p.sim_s for p in result.phases)
    return (sim / wall, sim / cpu) if wall > 0 and cpu > 0 else (0.0, 0.0)


def _rtf_rows(delivery: list[dict[str, Any]]) -> list[dict[str, Any]]:
    line = scene_rtf((*ARMS, CONVEYOR))
    single = scene_rtf((ARMS[0],))
    pick_and_place = _pick_and_place_rtf()

    def row(what: str, robots: int, measured: dict[str, Any]) -> dict[str, Any]:
        per = measured["per_sim_s"]
        return {
            "scene": what,
            "robots": robots,
            "rtf": measured["rtf"],
            "rtf_cpu": measured["rtf_cpu"],
            "joint_states_per_robot_hz": round(
                statistics.mean(v for k, v in per.items() if " " not in k and "/" not in k), 1
            ),
            "tf_hz": per.get("/tf", 0.0),
            "feedback_per_robot_hz": round(
                statistics.mean(v for k, v in per.items() if k.endswith(" feedback")), 1
            ),
        }

    return [
        row("line: 2 arms + conveyor, steady", 3, line),
        row("single arm (arm_in alone), steady", 1, single),
        {"scene": f"line demo, {len(delivery) - 1} seeds (median)", "robots": 3,
         "rtf": delivery[-1]["rtf"], "rtf_cpu": delivery[-1]["rtf_cpu"],
         "joint_states_per_robot_hz": "", "tf_hz": "", "feedback_per_robot_hz": ""},
        {"scene": "pick-and-place demo (no ROS traffic)", "robots": 1,
         "rtf": round(pick_and_place[0], 1), "rtf_cpu": round(pick_and_place[1], 1),
         "joint_states_per_robot_hz": "", "tf_hz": "", "feedback_per_robot_hz": ""},
    ]  # fmt: skip


def run(seeds: tuple[int, ...] = SEEDS) -> dict[str, list[dict[str, Any]]]:
    """The delivery table over ``seeds`` and the real-time factor table of the same run."""
    delivery = _delivery(seeds)
    return {
        f"Line demo, {len(seeds)} seeds x {PARTS} parts (target: >= 95% delivered within 2 cm)":
            delivery,
        "Line vs single arm, headless, every robot's joint states, /tf and action feedback "
        "published (target: line >= 5x real time)": _rtf_rows(delivery),
    }  # fmt: skip


if __name__ == "__main__":
    import sys

    from benchmarks.table import format_table

    for title, table in run().items():
        print(f"### {title}\n")
        print(format_table(table, markdown="--markdown" in sys.argv) + "\n")
