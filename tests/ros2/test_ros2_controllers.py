"""The sim's FollowJointTrajectory and GripperCommand controllers from a plain rclpy
ActionClient, through `simbridge endpoint --backend ros2` (the `action_servers` extension).

The sim runs here (its connector takes ROS 2 from the handshake and serves the controllers'
actions through the endpoint); the endpoint and the action client (tests/ros2/action_driver.py)
are processes of the ROS 2 venv. Trajectories are a second or so of sim time, run in real time.
The messages have control_msgs 5.x (Jazzy) layouts, and the type hashes the graph announces
are Jazzy's: those of a client built against the real control_msgs (MoveIt 2's).
"""

from __future__ import annotations

import logging
import os
import signal
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from simbridge.sim.runner import SimulationSession
from tests.ros2.action_rig import ActionRig, action_rig
from tests.ros2support import ActionDriver
from tests.sim.worlds import arm_scene

pytestmark = [pytest.mark.ros2, pytest.mark.timeout(300)]

FOLLOW = "control_msgs/action/FollowJointTrajectory"
GRIPPER = "control_msgs/action/GripperCommand"
ARM = "/arm_left/arm_controller/follow_joint_trajectory"
GRIP = "/arm_left/gripper_controller/gripper_cmd"
ACTIVE = {1, 2, 3}
"""ROS 2 goal statuses of a goal that has not ended (accepted, executing, canceling)."""
SUCCEEDED, CANCELED, ABORTED = 4, 5, 6
WAIT = 60.0
JAZZY_TYPE_HASHES = {
    "control_msgs/msg/JointTrajectoryControllerState": (
        "RIHS01_51d8dd89cc624cbe9daaeeb4d80d6de9b86168ffdc3be41fefc0953e3c26e480"
    ),
    "control_msgs/action/FollowJointTrajectory_FeedbackMessage": (
        "RIHS01_80398fcb9674a79081a9906e2ccf0c804dd7cb15e22e362e606ee87186beab71"
    ),
    "control_msgs/action/GripperCommand_FeedbackMessage": (
        "RIHS01_392ff03fcd872f9dc2405cbeb2897fcf011ad9998458b6aa85c603b8a49e431d"
    ),
}
"""RIHS01 hashes of control_msgs 5.8.0 (Jazzy), computed by rosidl_generator_type_description
4.6.6 from that release's definitions; the state's is also what `ros2 topic info -v` shows for
a ros2_control joint_trajectory_controller on Jazzy."""


def arm_goal(driver: ActionDriver, tag: str, values: dict[str, Any]) -> None:
    driver.goal(tag, values, action=ARM, kind=FOLLOW)


def _duration(t: float) -> dict[str, int]:
    return {"sec": int(t), "nanosec": round((t - int(t)) * 1e9)}


def _trajectory(
    names: list[str],
    points: list[tuple[float, list[float]]],
    goal_tolerance: dict[str, float] | None = None,
    path_tolerance: dict[str, float] | None = None,
    goal_time: float = 0.0,
) -> dict[str, Any]:
    """A FollowJointTrajectory goal as the driver's JSON."""
    return {
        "trajectory": {
            "joint_names": names,
            "points": [{"positions": q, "time_from_start": _duration(t)} for t, q in points],
        },
        "goal_tolerance": [{"name": n, "position": v} for n, v in (goal_tolerance or {}).items()],
        "path_tolerance": [{"name": n, "position": v} for n, v in (path_tolerance or {}).items()],
        "goal_time_tolerance": _duration(goal_time),
    }


def announced_type_hashes(driver: ActionDriver, topic: str) -> set[str]:
    """The type hashes the publishers of `topic` announce on the ROS 2 graph (one publisher;
    a previous test's sim may still be leaving)."""
    driver.send(op="type_hashes", topic=topic)
    return set(driver.reply("type_hashes", topic)["hashes"])


def _scene(tmp_path: Path) -> Path:
    robot = {
        "urdf": "arm.urdf",
        "ros": {
            "namespace": "/arm_left",
            "frame_prefix": "arm_left/",
            "controllers": {
                "arm_controller": {
                    "type": "joint_trajectory_controller",
                    "joints": ["shoulder", "elbow", "wrist"],
                    "constraints": {"goal_time": 0.5, "elbow": {"goal": 0.01}},
                },
                "gripper_controller": {
                    "type": "gripper_action_controller",
                    "joint": "grip_a",
                    "stall_timeout": 0.2,
                    "goal_tolerance": 0.002,
                },
            },
        },
    }
    scene = {"physics": {"timestep": 0.002, "gravity": [0, 0, 0]}, "robots": [robot]}
    return arm_scene(tmp_path, scene)


class Sim:
    """A simulation session on the endpoint, stepping in real time on a thread."""

    def __init__(self, scene: Path, port: int) -> None:
        self.session = SimulationSession(scene, f"127.0.0.1:{port}", connect_timeout=30)
        self.session.__enter__()
        self.runner = threading.Thread(target=self.session.run, kwargs={"realtime_factor": 1.0})
        self.runner.start()

    def close(self) -> None:
        self.session.world.stop()
        self.runner.join(30)
        self.session.__exit__(None, None, None)


@pytest.fixture(scope="module")
def rig() -> Iterator[ActionRig]:
    yield from action_rig()


@pytest.fixture
def sim(tmp_path: Path, rig: ActionRig) -> Iterator[Sim]:
    running = Sim(_scene(tmp_path), rig.port)
    try:
        rig.driver.wait_ready(ARM, FOLLOW)
        yield running
    finally:
        running.close()


def _succeeds_at(driver: ActionDriver, goal: str, *, shoulder: float, elbow: float) -> None:
    """The goal's result is SUCCEEDED with error code 0 and the arm stands at the target."""
    result = driver.reply("result", goal)
    assert (result["status"], result["values"]["error_code"]) == (SUCCEEDED, 0)
    driver.send(op="joints", topic="/arm_left/joint_states")
    joints = driver.expect(lambda o: "joints" in o)["joints"]
    assert joints["elbow"] == pytest.approx(elbow, abs=0.01)  # the goal tolerance
    assert joints["shoulder"] == pytest.approx(shoulder, abs=0.05)


def test_goal_succeeds_with_feedback_and_the_joints_reach_the_target(
    sim: Sim, rig: ActionRig
) -> None:
    driver = rig.driver
    driver.send(op="state", topic="/arm_left/arm_controller/state")
    state = driver.expect(lambda o: "state" in o)["state"]
    assert state["joint_names"] == ["shoulder", "elbow", "wrist"]
    # Jazzy's state: the loop's terms, no multi-DOF joints, no speed scaling.
    for term in ("reference", "feedback", "error", "output"):
        assert len(state[term]["positions"]) == 3, term
    assert (state["multi_dof_joint_names"], state["speed_scaling_factor"]) == ([], 1.0)
    assert state["multi_dof_reference"]["transforms"] == []
    assert announced_type_hashes(driver, "/arm_left/arm_controller/state") == {
        JAZZY_TYPE_HASHES["control_msgs/msg/JointTrajectoryControllerState"]
    }
    arm_goal(
        driver,
        "reach",
        _trajectory(["shoulder", "elbow"], [(0.5, [0.2, -0.3]), (1.0, [0.4, -0.6])]),
    )
    assert driver.reply("accepted", "reach")["ok"] is True
    _succeeds_at(driver, "reach", shoulder=0.4, elbow=-0.6)


def test_error_codes_as_on_ros1(sim: Sim, rig: ActionRig) -> None:
    """INVALID_JOINTS and INVALID_GOAL (accepted, then aborted with the code: a ROS 2
    rejection carries no result), PATH_TOLERANCE_VIOLATED, GOAL_TOLERANCE_VIOLATED, and
    INVALID_JOINTS for ROS 2's multi-DOF trajectory (the sim has no multi-DOF joints)."""
    driver = rig.driver
    arm_goal(driver, "joints", _trajectory(["shoulder", "grip_a"], [(0.2, [0.1, 0.01])]))
    floating = {
        "joint_names": ["base"],
        "points": [{"transforms": [{"rotation": {"w": 1.0}}], "time_from_start": _duration(1)}],
    }
    multi_dof = {**_trajectory(["shoulder"], [(1.0, [0.1])]), "multi_dof_trajectory": floating}
    arm_goal(driver, "multi_dof", multi_dof)
    arm_goal(driver, "empty", _trajectory(["shoulder"], []))
    # A jump no drive follows within 0.001 rad; the wrist cannot reach 3 rad in 0.07 s.
    arm_goal(
        driver,
        "path",
        _trajectory(
            ["shoulder"], [(0.05, [1.5]), (1.0, [1.5])], path_tolerance={"shoulder": 0.001}
        ),
    )
    tags = ("joints", "multi_dof", "empty", "path")
    results = {tag: driver.reply("result", tag) for tag in tags}
    arm_goal(
        driver,
        "end",
        _trajectory(["wrist"], [(0.02, [3.0])], goal_tolerance={"wrist": 1e-6}, goal_time=0.05),
    )
    results["end"] = driver.reply("result", "end")
    codes = {tag: (r["status"], r["values"]["error_code"]) for tag, r in results.items()}
    assert codes == {
        "joints": (ABORTED, -2),
        "multi_dof": (ABORTED, -2),
        "empty": (ABORTED, -1),
        "path": (ABORTED, -4),
        "end": (ABORTED, -5),
    }
    assert "grip_a" in results["joints"]["values"]["error_string"]
    assert "['base']" in results["multi_dof"]["values"]["error_string"]
    assert "shoulder" in results["path"]["values"]["error_string"]
    assert "wrist" in results["end"]["values"]["error_string"]


def test_feedback_then_cancel_ends_the_goal_canceled(sim: Sim, rig: ActionRig) -> None:
    driver = rig.driver
    arm_goal(driver, "long", _trajectory(["elbow"], [(20.0, [1.0])]))
    assert driver.reply("accepted", "long")["ok"] is True
    # 20 Hz of sim time; the first may come late (the feedback topic's own discovery).
    feedback = driver.reply("feedback", "long")
    assert feedback["joint_names"] == ["shoulder", "elbow", "wrist"]
    values = feedback["values"]
    for term in ("desired", "actual", "error"):
        assert len(values[term]["positions"]) == 3, term
    desired, actual = values["desired"]["positions"][1], values["actual"]["positions"][1]
    assert values["error"]["positions"][1] == pytest.approx(desired - actual)
    assert (values["multi_dof_joint_names"], values["multi_dof_error"]["transforms"]) == ([], [])
    assert announced_type_hashes(driver, f"{ARM}/_action/feedback") == {
        JAZZY_TYPE_HASHES["control_msgs/action/FollowJointTrajectory_FeedbackMessage"]
    }
    driver.send(op="cancel", tag="long")
    answer = driver.reply("cancel", "long")
    assert (answer["return_code"], answer["canceling"]) == (0, 1)
    result = driver.reply("result", "long")
    assert result["status"] == CANCELED
    driver.send(op="joints", topic="/arm_left/joint_states")
    assert driver.expect(lambda o: "joints" in o)["joints"]["elbow"] < 0.9  # stopped early


def test_a_new_goal_preempts_the_running_one(sim: Sim, rig: ActionRig) -> None:
    driver = rig.driver
    arm_goal(driver, "first", _trajectory(["elbow"], [(20.0, [1.0])]))
    assert driver.reply("accepted", "first")["ok"] is True
    arm_goal(driver, "second", _trajectory(["elbow"], [(1.0, [-0.5])]))
    assert driver.reply("accepted", "second")["ok"] is True
    first = driver.reply("result", "first")
    assert first["status"] == CANCELED
    assert "preempted" in first["values"]["error_string"]
    second = driver.reply("result", "second")
    assert (second["status"], second["values"]["error_code"]) == (SUCCEEDED, 0)


def test_gripper_reaches_its_goal_and_stalls_at_the_limit(sim: Sim, rig: ActionRig) -> None:
    driver = rig.driver
    driver.wait_ready(GRIP, GRIPPER)
    assert announced_type_hashes(driver, f"{GRIP}/_action/feedback") == {
        JAZZY_TYPE_HASHES["control_msgs/action/GripperCommand_FeedbackMessage"]
    }
    command = {"command": {"position": 0.03, "max_effort": 5.0}}
    driver.goal("grip", command, action=GRIP, kind=GRIPPER)
    assert driver.reply("accepted", "grip")["ok"] is True
    reached = driver.reply("result", "grip")
    assert (reached["status"], reached["values"]["reached_goal"]) == (SUCCEEDED, True)
    assert reached["values"]["position"] == pytest.approx(0.03, abs=0.004)
    driver.goal("limit", {"command": {"position": 0.09}}, action=GRIP, kind=GRIPPER)
    stalled = driver.reply("result", "limit")  # the joint stops at its 0.05 m limit
    assert (stalled["status"], stalled["values"]["stalled"]) == (ABORTED, True)
    assert stalled["values"]["position"] == pytest.approx(0.05, abs=5e-3)


def test_the_sim_going_away_aborts_its_goals(tmp_path: Path, rig: ActionRig) -> None:
    driver = rig.driver
    running = Sim(_scene(tmp_path), rig.port)
    try:
        driver.wait_ready(ARM, FOLLOW)
        arm_goal(driver, "orphan", _trajectory(["elbow"], [(30.0, [1.0])]))
        assert driver.reply("accepted", "orphan")["ok"] is True
    finally:
        running.close()
    assert driver.reply("result", "orphan")["status"] == ABORTED


def goal_statuses(driver: ActionDriver, action: str) -> dict[str, int]:
    """The goals (hex UUID -> status) in the latest status array `action`'s server published."""
    driver.send(op="status", action=action)
    return dict(driver.reply("status", action)["goals"])


def started_driver() -> ActionDriver:
    """A new rclpy action client process, up and with the arm's server discovered."""
    driver = ActionDriver()
    driver.expect(lambda o: o.get("up") is True)
    driver.wait_ready(ARM, FOLLOW)
    return driver


def test_a_client_killed_mid_goal_leaves_it_to_finish_and_a_new_client_drives_the_arm(
    sim: Sim, rig: ActionRig, caplog: pytest.LogCaptureFixture
) -> None:
    """An rclpy client process SIGKILLed while its goal runs. ROS 2 actions have no client
    liveness, so nothing tells the endpoint or the sim: the goal runs to its end and
    SUCCEEDS (rclpy keeps its result for the result timeout, 900 s, as for any client that
    never asks). Nothing crashes, no goal is left active, and a new client process drives
    the same controller to its target."""
    caplog.set_level(logging.ERROR)
    logged = len(rig.endpoint.output)
    doomed = started_driver()
    try:
        arm_goal(doomed, "doomed", _trajectory(["elbow"], [(6.0, [0.8])]))
        accepted = doomed.reply("accepted", "doomed")
        assert accepted["ok"] is True
        doomed.reply("feedback", "doomed")  # the goal runs
        os.killpg(doomed.proc.proc.pid, signal.SIGKILL)
        assert doomed.proc.proc.wait(30) == -signal.SIGKILL
    finally:
        doomed.proc.stop()
    # It died mid-goal: no result had reached it.
    assert not any('"result"' in line for line in doomed.proc.output), doomed.proc.output
    orphan = accepted["goal_id"]

    fresh = started_driver()
    try:
        deadline = time.monotonic() + WAIT
        statuses = goal_statuses(fresh, ARM)
        while statuses.get(orphan) in ACTIVE and time.monotonic() < deadline:
            time.sleep(0.5)
            statuses = goal_statuses(fresh, ARM)
        assert statuses[orphan] == SUCCEEDED, statuses
        fresh.send(op="joints", topic="/arm_left/joint_states")
        assert fresh.expect(lambda o: "joints" in o)["joints"]["elbow"] == pytest.approx(
            0.8, abs=0.01
        )

        arm_goal(
            fresh,
            "after",
            _trajectory(["shoulder", "elbow"], [(1.0, [0.3, -0.4])], goal_time=0.5),
        )
        after = fresh.reply("accepted", "after")
        assert after["ok"] is True
        _succeeds_at(fresh, "after", shoulder=0.3, elbow=-0.4)
        # Nothing piled up: both goals ended, none is still active on the server.
        statuses = goal_statuses(fresh, ARM)
        assert (statuses[orphan], statuses[after["goal_id"]]) == (SUCCEEDED, SUCCEEDED)
        assert not [s for s in statuses.values() if s in ACTIVE], statuses
    finally:
        fresh.proc.stop()
    assert sim.runner.is_alive()
    assert rig.endpoint.proc.poll() is None
    endpoint_log = rig.endpoint.output[logged:]
    assert not [line for line in endpoint_log if "Traceback" in line or " ERROR " in line]
    assert [r.getMessage() for r in caplog.records if r.levelno >= logging.ERROR] == []
