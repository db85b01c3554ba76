"""Odometry publishes positive diagonal covariances, configurable per sensor (issue 11.10).

All-zero covariances claim perfect readings; robot_localization rejects such messages.
"""

from __future__ import annotations

import numpy as np
import pytest

from simbridge.errors import SimError
from simbridge.messages import default_registry
from simbridge.sim.sensors import build_sensor
from simbridge.sim.sensors.odometry import DEFAULT_POSE_COVARIANCE, DEFAULT_TWIST_COVARIANCE
from tests.sim.sensors.conftest import forward_model

BASE = """
<mujoco>
  <worldbody>
    <body name="base_link" pos="0 0 0.1"><freejoint/><geom type="box" size="0.2 0.1 0.05"/></body>
  </worldbody>
</mujoco>
"""


def _odometry(model, data, **options):
    sensor = build_sensor(model, {"type": "odometry", "name": "odom", "body": "base_link",
                                  "topic": "/odom", **options})  # fmt: skip
    (pub,) = [p for p in sensor.poll(model, data) if p.topic == "/odom"]
    return pub


def test_defaults_are_positive_diagonals():
    model, data = forward_model(BASE)
    msg = _odometry(model, data).message
    pose = np.asarray(msg.pose.covariance).reshape(6, 6)
    twist = np.asarray(msg.twist.covariance).reshape(6, 6)
    np.testing.assert_array_equal(pose, np.diag(DEFAULT_POSE_COVARIANCE))
    np.testing.assert_array_equal(twist, np.diag(DEFAULT_TWIST_COVARIANCE))
    assert (np.diag(pose) > 0).all()
    assert (np.diag(twist) > 0).all()


def test_scene_config_sets_them_and_they_survive_the_wire():
    model, data = forward_model(BASE)
    pose_diag = [0.01, 0.02, 1e6, 1e6, 1e6, 0.03]  # a planar robot: z, roll, pitch unknown
    twist_diag = [0.001, 0.002, 1e6, 1e6, 1e6, 0.003]
    pub = _odometry(
        model, data, pose_covariance_diagonal=pose_diag, twist_covariance_diagonal=twist_diag
    )
    registry = default_registry()
    back = registry.decode(registry.encode(pub.message, pub.msgtype), pub.msgtype)
    np.testing.assert_array_equal(np.asarray(back.pose.covariance).reshape(6, 6),
                                  np.diag(pose_diag))  # fmt: skip
    np.testing.assert_array_equal(np.asarray(back.twist.covariance).reshape(6, 6),
                                  np.diag(twist_diag))  # fmt: skip


@pytest.mark.parametrize(
    ("key", "value", "message"),
    [
        ("pose_covariance_diagonal", [0, 1, 1, 1, 1, 1], "finite variances > 0"),
        ("twist_covariance_diagonal", [1, 1, 1, 1, 1, -1], "finite variances > 0"),
        ("pose_covariance_diagonal", [1, 1, 1, 1, 1, float("nan")], "finite variances > 0"),
        ("pose_covariance_diagonal", [1, 1, 1], "needs 6 values"),
        ("twist_covariance_diagonal", "small", "needs 6 values|must be"),
    ],
)
def test_bad_values_name_the_key(key, value, message):
    model, data = forward_model(BASE)
    with pytest.raises(SimError, match=message) as error:
        _odometry(model, data, **{key: value})
    assert key in str(error.value)


def test_documented_example_builds():
    import re
    from pathlib import Path

    import yaml

    docs = Path(__file__).resolve().parents[3] / "docs" / "sensors.md"
    (block,) = [
        b
        for b in re.findall(r"```yaml\n(.*?)```", docs.read_text(), flags=re.DOTALL)
        if "pose_covariance_diagonal" in b
    ]
    (config,) = yaml.safe_load(block)
    model, data = forward_model(BASE)
    msg = _odometry(model, data, **{k: v for k, v in config.items() if k != "topic"}).message
    assert msg.pose.covariance[14] == 1e6  # z variance, row 2 column 2
    assert msg.twist.covariance[35] == 0.03
