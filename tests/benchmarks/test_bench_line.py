"""The line benchmark's real-time harness publishes what it claims for every robot."""

from __future__ import annotations

import pytest
from benchmarks.bench_line import scene_rtf

from simbridge.apps.line import ARMS, CONVEYOR


def test_every_robot_publishes_joint_states_tf_and_feedback_while_measured() -> None:
    measured = scene_rtf((*ARMS, CONVEYOR), sim_s=2.0)
    per = measured["per_sim_s"]
    assert measured["sim_s"] == pytest.approx(2.0, abs=0.01)
    assert measured["rtf"] > 0
    assert per["/tf"] == pytest.approx(50, rel=0.1)
    for robot in (*ARMS, CONVEYOR):
        assert per[robot] == pytest.approx(50, rel=0.1)  # <ns>/joint_states
        assert per[f"{robot} feedback"] == pytest.approx(20, rel=0.15)  # action feedback
        assert per[f"{robot} state"] == pytest.approx(25, rel=0.1)  # controller state


def test_single_arm_scene_holds_only_that_arm() -> None:
    per = scene_rtf((ARMS[0],), sim_s=1.0)["per_sim_s"]
    assert per[ARMS[0]] == pytest.approx(50, rel=0.1)
    assert ARMS[1] not in per
    assert CONVEYOR not in per
