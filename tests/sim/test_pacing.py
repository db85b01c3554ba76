"""A scene serving a ROS graph runs at real time unless asked otherwise (issue 11.3).

The mobile-robot scene says `realtime_factor: 0` for its in-process demo; under
`simbridge sim --endpoint` it ran 18x faster than real time, so a 10 Hz wall-clock
`/cmd_vel` stream reached it at well under 1 Hz of sim time and its command timeout
braked the robot.
"""

from __future__ import annotations

import re
import threading
from pathlib import Path

import pytest
import yaml

from simbridge.apps.mobile_robot import runner as mobile_robot
from simbridge.cli import main
from simbridge.endpoint import EndpointOptions, EndpointThread, LocalBus, Node
from simbridge.messages import default_registry
from simbridge.sim.runner import SimulationSession
from tests.sim.urdf_samples import GRAVITY_ARM

MOBILE_SCENE = Path(mobile_robot.__file__).parent / "scene.yaml"


def _unpaced_arm_scene(tmp_path: Path) -> Path:
    (tmp_path / "arm.urdf").write_text(GRAVITY_ARM)
    scene = tmp_path / "scene.yaml"
    scene.write_text(
        yaml.safe_dump({"physics": {"realtime_factor": 0}, "robots": [{"urdf": "arm.urdf"}]})
    )
    return scene


def _factor(output: str) -> float:
    match = re.search(r"\(\d+ steps, ([\d.]+)x real time\)", output)
    assert match, output
    return float(match.group(1))


def test_help_states_the_real_default(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(["sim", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "default: 1 with --endpoint" in text
    assert "default: as fast as possible" not in text


def test_sim_with_an_endpoint_defaults_to_real_time(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    scene = _unpaced_arm_scene(tmp_path)
    with EndpointThread(EndpointOptions(port=0)) as endpoint:
        address = f"127.0.0.1:{endpoint.port}"
        assert main(["sim", str(scene), "--endpoint", address, "--duration", "0.6"]) == 0
        paced = _factor(capsys.readouterr().out)
        assert main(["sim", str(scene), "--endpoint", address, "--duration", "0.6",
                     "--realtime", "0"]) == 0  # fmt: skip
        asked_unpaced = _factor(capsys.readouterr().out)
    assert main(["sim", str(scene), "--duration", "0.6"]) == 0  # no ROS: the scene's 0
    no_ros = _factor(capsys.readouterr().out)
    assert 0.5 < paced <= 1.05
    assert asked_unpaced > 1.5
    assert no_ros > 1.5


def test_wall_clock_cmd_vel_drives_the_mobile_robot_scene() -> None:
    """A 10 Hz wall-clock command stream keeps the robot going (0.3 m/s for 2.5 s of sim
    time, less the acceleration ramp: about 0.7 m); unpaced it stopped and started."""
    registry = default_registry()
    twist = registry.new("geometry_msgs/Twist")
    twist.linear.x = 0.3
    stop = threading.Event()
    with EndpointThread(EndpointOptions(port=0)) as endpoint:
        assert isinstance(endpoint.backend, LocalBus)
        with Node(endpoint.backend, "/teleop") as node:
            cmd_vel = node.advertise("/cmd_vel", "geometry_msgs/Twist")

            def publish_at_10_hz() -> None:
                while not stop.wait(0.1):
                    cmd_vel.publish(twist)

            sender = threading.Thread(target=publish_at_10_hz, daemon=True)
            address = f"127.0.0.1:{endpoint.port}"
            with SimulationSession(MOBILE_SCENE, address, connect_timeout=5) as session:
                assert session.connector is not None
                assert session.connector.flush(5)
                session.connector.endpoint_stats()  # a barrier: /cmd_vel is subscribed
                sender.start()
                try:
                    stats = session.run(duration=2.5)
                finally:
                    stop.set()
                    sender.join(5)
                x = float(session.world.link_pose("base_link").xyz[0])
    assert 0.55 < x < 0.8
    assert stats.realtime_factor <= 1.05
    assert session.pacing() == 1.0
