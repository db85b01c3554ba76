"""The line demo on the local backend: parts delivered through the controllers' actions,
the --json line, every robot's namespaced topics, TF frames and action servers, and
clear errors for bad options."""

from __future__ import annotations

import json
import threading
from collections import Counter
from collections.abc import Callable
from pathlib import Path

import pytest
from PIL import Image
from rosbags.highlevel import AnyReader

from simbridge.apps.line import (
    ARMS,
    CONVEYOR,
    DELIVERY_TOLERANCE_M,
    SCENE_PATH,
    LineResult,
    LineTask,
    line_scene,
    main,
    run_line,
)
from simbridge.apps.line.scene import grasp_contacts
from simbridge.apps.line.task import MAX_PARTS
from simbridge.apps.options import LINE_MAX_PARTS
from simbridge.apps.summary import SUMMARY_KEYS
from simbridge.cli import main as cli_main
from simbridge.connector import ConnectorOptions
from simbridge.endpoint import EndpointOptions, EndpointThread, LocalBus, Node
from simbridge.sim.runner import SimulationSession
from tests.waiting import wait_for

ROBOTS = (*ARMS, CONVEYOR)


@pytest.mark.parametrize("seed", [1, 2])
def test_parts_move_from_input_to_output_by_physics(seed: int) -> None:
    lines: list[str] = []
    result = run_line(seed, parts=2, progress=lines.append)
    assert result.error is None, "\n".join(lines)
    assert result.success
    assert result.delivered == result.parts == 2
    assert all(0 <= e <= DELIVERY_TOLERANCE_M for e in result.placement_error_m)
    task = LineTask.random(seed, 2)
    for final, start in zip(result.final_positions, task.parts, strict=True):
        # each part really travelled: from y > 0.3 (input) to y < -0.3 (output)
        assert start.y > 0.3
        assert final[1] < -0.3
    # every robot was driven by action goals and answered with feedback and joint states
    for name in ROBOTS:
        tally = result.robots[name]
        assert tally["namespace"] == f"/{name}"
        assert tally["goals"] > 0
        assert tally["feedback"] > 0
        assert tally["joint_states"] > 0
    assert result.robots["arm_in"]["goals"] == 2 * 7  # 5 trajectories, 2 gripper goals a part
    assert 0 < result.cycle_s < result.sim_s


def test_json_line_has_the_documented_shape_and_the_bag_every_robot(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bag = tmp_path / "line.mcap"
    assert main(["--seed", "3", "--parts", "1", "--json", "--record", str(bag)]) == 0
    last = capsys.readouterr().out.strip().splitlines()[-1]
    summary = json.loads(last)
    for key, kind in {
        "success": bool, "parts": int, "delivered": int, "placement_error_m": list,
        "cycle_s": float, "sim_s": float, "wall_s": float, "robots": dict,
    }.items():  # fmt: skip
        assert isinstance(summary[key], kind), key
    assert summary["success"] is True
    assert list(summary)[:7] == list(SUMMARY_KEYS)
    assert LINE_MAX_PARTS == MAX_PARTS  # the --parts help matches the output slots
    assert (summary["seed"], summary["backend"]) == (3, "local")
    assert summary["parts"] == summary["delivered"] == 1
    assert len(summary["placement_error_m"]) == 1
    assert set(summary["robots"]) == set(ROBOTS)
    with AnyReader([bag]) as reader:
        topics = Counter(connection.topic for connection, _, _ in reader.messages())
    for robot, controller in (("arm_in", "arm"), ("arm_out", "arm"), (CONVEYOR, "pallet")):
        assert topics[f"/{robot}/joint_states"] > 100
        assert topics[f"/{robot}/{controller}_controller/follow_joint_trajectory/goal"] >= 1
        assert topics[f"/{robot}/{controller}_controller/follow_joint_trajectory/feedback"] > 0
    assert topics["/tf"] > 100


def test_every_robot_has_its_own_namespaced_topics_frames_and_actions() -> None:
    task = LineTask.random(0, 1)
    bus = LocalBus()
    with (
        EndpointThread(EndpointOptions(port=0), bus) as endpoint,
        SimulationSession(
            line_scene(task, SCENE_PATH),
            f"127.0.0.1:{endpoint.port}",
            ConnectorOptions(reconnect_initial=0.2),
            connect_timeout=5.0,
            extensions=grasp_contacts(task),
        ) as session,
        Node(bus, "/probe") as probe,
    ):
        assert set(session.robot_bridges) == set(ROBOTS)  # each on its own connection
        names: dict[str, list[str]] = {}
        frames: set[str] = set()
        lock = threading.Lock()

        def joints(robot: str) -> Callable[[object], None]:
            def keep(msg: object) -> None:
                with lock:
                    names[robot] = list(msg.name)  # type: ignore[attr-defined]

            return keep

        def tf(msg: object) -> None:
            with lock:
                frames.update(t.child_frame_id for t in msg.transforms)  # type: ignore[attr-defined]

        for robot in ROBOTS:
            probe.subscribe(f"/{robot}/joint_states", "sensor_msgs/JointState", joints(robot))
        probe.subscribe("/tf", "tf2_msgs/TFMessage", tf)
        runner = threading.Thread(target=session.world.run, args=(2.0, 0.0))
        runner.start()
        try:
            assert wait_for(
                lambda: len(names) == 3 and "conveyor/pallet_link" in frames, timeout=10
            )
        finally:
            session.world.stop()
            runner.join(10)
        topics = {info.name for info in bus.topics()}
    # two copies of one URDF: the same joint names under two namespaces
    assert names["arm_in"] == names["arm_out"]
    assert "joint_1" in names["arm_in"]
    assert names["conveyor"] == ["pallet_joint"]
    for arm in ARMS:
        assert f"{arm}/shoulder_link" in frames
        for action in ("arm_controller/follow_joint_trajectory", "gripper_controller/gripper_cmd"):
            assert {f"/{arm}/{action}/{t}" for t in ("goal", "feedback", "result")} <= topics
        assert f"/{arm}/arm_controller/state" in topics
    assert "/conveyor/pallet_controller/follow_joint_trajectory/feedback" in topics


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--parts", "9"], "--parts must be 1 to 4, got 9"),
        (["--video", "run.avi"], "unknown format '.avi'"),
        (["--realtime", "-1"], "--realtime must be >= 0, got -1.0"),
    ],
)
def test_bad_options_get_a_clear_error(
    argv: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(argv) == 2
    assert message in capsys.readouterr().err


def test_cli_offers_every_backend_and_refuses_others(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exited:
        cli_main(["demo", "line", "--backend", "ros3"])
    assert exited.value.code == 2
    err = capsys.readouterr().err
    assert "argument --backend: invalid choice: 'ros3'" in err
    assert "--backend {local,ros1,ros2}" in err


def test_result_counts_only_parts_within_tolerance() -> None:
    result = LineResult(
        parts=2, delivered=1, placement_error_m=(0.004, 0.05), cycle_s=10.0, sim_s=25.0,
        wall_s=5.0, robots={},
    )  # fmt: skip
    assert not result.success
    assert result.realtime_factor == pytest.approx(5.0)
    assert result.to_dict()["delivered"] == 1


def test_video_renders_the_run(tmp_path: Path) -> None:
    path = tmp_path / "line.gif"
    result = run_line(5, parts=1, video=path, progress=None)
    assert result.success
    assert result.video == str(path)
    with Image.open(path) as gif:
        size = gif.size
        shown_ms = 0
        for index in range(getattr(gif, "n_frames", 1)):
            gif.seek(index)
            shown_ms += gif.info["duration"]
    # 15 frames per sim second for the whole run, counted as playing time: Pillow merges
    # identical consecutive frames into one longer frame (a still scene renders alike on EGL)
    assert 0.9 * result.sim_s * 1000 <= shown_ms <= 1.1 * result.sim_s * 1000
    assert size == (480, 360)
