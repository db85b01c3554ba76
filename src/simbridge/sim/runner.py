"""The sim's top-level runner: a scene's world with its ROS side, recording and live view;
what `simbridge sim SCENE.yaml [--endpoint host:port]` runs."""

from __future__ import annotations

import contextlib
import logging
import time
from collections.abc import Callable, Sequence
from pathlib import Path

from simbridge.connector import Connector, ConnectorOptions
from simbridge.errors import SimError
from simbridge.progress import Ticker
from simbridge.sim.record import Recorder, RecordOptions
from simbridge.sim.ros.bridge import SimRosBridge
from simbridge.sim.ros.params import description_params
from simbridge.sim.ros.robot_bridge import RobotBridge
from simbridge.sim.ros.sensor_publisher import SensorPublisher
from simbridge.sim.scene.loader import load_scene
from simbridge.sim.scene.spec import Scene
from simbridge.sim.sensors import SensorSuite
from simbridge.sim.view import LiveView, ViewOptions
from simbridge.sim.world.world import ModelExtension, RunStats, World

__all__ = ["SimulationSession", "parse_endpoint", "run_scene"]

_log = logging.getLogger("simbridge.sim.runner")


def parse_endpoint(text: str) -> tuple[str, int]:
    """("host", port) from "host:port" (or ":port" for localhost)."""
    host, sep, port_text = text.rpartition(":")
    try:
        port = int(port_text)
    except ValueError:
        port = -1
    if not sep or not 0 < port < 65536:
        raise SimError(f"endpoint '{text}' is not host:port (e.g. 127.0.0.1:10000)")
    return host or "127.0.0.1", port


class SimulationSession:
    """A `World` from a scene plus, given an endpoint, a connector with the scene's ROS
    interfaces and sensors. Use as a context manager, or `start()` then `close()`."""

    def __init__(
        self,
        scene: Scene | str | Path,
        endpoint: str | None = None,
        connector_options: ConnectorOptions | None = None,
        connect_timeout: float | None = None,
        record: RecordOptions | None = None,
        *,
        extensions: Sequence[ModelExtension] = (),
        connect: Callable[[], Connector] | None = None,
    ) -> None:
        """`record`: write every message the session publishes or receives to a bag
        (needs an endpoint). `extensions`: MJCF edits for `World.from_scene` (contacts
        tuned for grasping, markers). `connect`: makes each of the session's connectors
        instead of dialing `endpoint` (the sim's own ROS 2 node, `simbridge.apps.ros2_node`)."""
        if record is not None and not endpoint and connect is None:
            raise SimError(
                f"recording to '{record.path}' needs an endpoint: the simulation publishes "
                "nothing without one (give --endpoint HOST:PORT)"
            )
        self.scene = scene if isinstance(scene, Scene) else load_scene(scene)
        self.world = World.from_scene(self.scene, extensions)
        self.connector: Connector | None = None
        self.bridge: SimRosBridge | None = None
        self.recorder: Recorder | None = None
        self.robot_bridges: dict[str, RobotBridge] = {}
        """Robots with `own_connection`: their bridges, each on a connector of its own."""
        self._record = record
        self._endpoint = parse_endpoint(endpoint) if endpoint else None
        self._options = connector_options
        self._connect_timeout = connect_timeout
        self._connect = connect

    def start(self) -> SimulationSession:
        """Connect (in the background unless the session has a `connect_timeout`; the
        connector keeps retrying) and register every topic and service the scene asks for."""
        served = self._endpoint is not None or self._connect is not None
        if not served or not self.scene.ros.enabled or self.connector is not None:
            return self
        self.connector = self._new_connector()
        for name, description in description_params(self.world).items():
            self.connector.set_param(name, description)  # for RViz's RobotModel
        if self._record is not None:
            world = self.world
            self.recorder = Recorder(self._record, clock=lambda: world.time)
            self.recorder.attach(self.connector)
        own = frozenset(
            name
            for name, robot in self.world.robots.items()
            if robot.built.spec.ros is not None and robot.built.spec.ros.own_connection
        )
        suite = (
            SensorSuite.from_config(self.world.model, self.scene.sensors)
            if self.scene.sensors
            else None
        )
        self.bridge = SimRosBridge(
            self.world,
            self.connector,
            self.scene.ros,
            elsewhere=own,
            sensors=suite,
            measure_all=self.recorder is not None,  # the bag listens to all
        )
        for name in sorted(own):
            connector = self._new_connector()
            if self.recorder is not None:
                self.recorder.attach(connector)
            self.robot_bridges[name] = RobotBridge(
                self.world, connector, self.world.robots[name], self.scene.ros
            ).start()
        self.bridge.start()
        return self

    def _new_connector(self) -> Connector:
        """A connector of the session: `connect()`'s, else one dialing the endpoint."""
        if self._connect is not None:
            return self._connect()
        assert self._endpoint is not None
        host, port = self._endpoint
        return Connector(host, port, self._options).connect(wait=self._connect_timeout)

    @property
    def sensors(self) -> SensorPublisher | None:
        """The scene's sensors on the session's connector (None without sensors or ROS)."""
        return self.bridge.sensors if self.bridge is not None else None

    def run(
        self,
        duration: float | None = None,
        realtime_factor: float | None = None,
        viewer: bool = False,
    ) -> RunStats:
        """Run the world (see `World.run`) at `realtime_factor`, which defaults to
        `pacing()`."""
        factor = self.pacing() if realtime_factor is None else realtime_factor
        source = self.scene.source.name if self.scene.source is not None else "scene"
        _log.info(
            "simulating %s: %d robot(s), %g ms step, %s, %s",
            source,
            len(self.world.robots),
            self.world.timestep * 1000,
            f"{factor:g}x real time" if factor > 0 else "as fast as possible",
            f"for {duration:g} s" if duration is not None else "until Ctrl-C or SIGTERM",
        )
        return self.world.run(duration, factor, viewer)

    def pacing(self) -> float:
        """The default real-time factor: 1 while serving a ROS graph, whatever the scene
        says, because ROS nodes, wall-clock timers and `rostopic pub -r` commands expect
        sim time to follow real time (an unpaced run turns a 10 Hz command stream into
        well under 1 Hz of sim time). Without ROS, the scene's `physics.realtime_factor`."""
        scene_factor = self.scene.physics.realtime_factor
        if self.connector is None or scene_factor == 1.0:
            return scene_factor
        _log.info(
            "serving ROS at real time; the scene's realtime_factor %g applies only without "
            "an endpoint (pass realtime_factor / --realtime to change the pace)",
            scene_factor,
        )
        return 1.0

    def close(self) -> None:
        """Unregister and disconnect."""
        if self.bridge is not None:
            self.bridge.close()
        for robot in self.robot_bridges.values():
            robot.close()
            robot.connector.close()
        self.robot_bridges.clear()
        if self.connector is not None:
            self.connector.close()
        if self.recorder is not None:
            _log.info("%s", self.recorder.close().summary())
            self.recorder = None

    def __enter__(self) -> SimulationSession:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()


def run_scene(
    scene: Scene | str | Path,
    *,
    endpoint: str | None = None,
    duration: float | None = None,
    realtime_factor: float | None = None,
    viewer: bool = False,
    record: RecordOptions | None = None,
    view: ViewOptions | None = None,
    connect_timeout: float | None = None,
    progress: bool = False,
    connect: Callable[[], Connector] | None = None,
) -> RunStats:
    """Load and run a scene headless (or in the viewer) until `duration` sim seconds pass
    or the process is interrupted, serving ROS through `endpoint` ("host:port") if given.
    `realtime_factor` None: real time with an endpoint, else the scene's
    (`SimulationSession.pacing`). `record`: a bag of every message in and out; `view`:
    serve a live 3D view in the browser while it runs. `connect_timeout`: ConnectorError
    when no endpoint answers that soon (None: connect in the background, retrying).
    `progress`: while recording, a status line on stderr (`simbridge.progress.Ticker`).
    `connect`: makes the session's connectors instead of dialing `endpoint`."""
    with SimulationSession(
        scene, endpoint, record=record, connect_timeout=connect_timeout, connect=connect
    ) as session:
        live = LiveView(session.world, view) if view is not None else None
        if live is not None and session.sensors is not None:
            session.sensors.add_observer(live.watch_sensors(session.sensors.suite))
        world = session.world
        steps, sim_start, wall_start = world.step_count, world.time, time.perf_counter()
        recorder = session.recorder
        ticker = (
            Ticker(lambda: f"{recorder.progress()}; sim {world.time:.1f} s")
            if progress and recorder is not None
            else contextlib.nullcontext()
        )
        try:
            with ticker:
                stats = session.run(duration, realtime_factor, viewer)
        except KeyboardInterrupt:  # what ran until then (a reset service restarts the count)
            return RunStats(
                max(0, world.step_count - steps),
                max(0.0, world.time - sim_start),
                time.perf_counter() - wall_start,
            )
        else:
            if live is not None and view is not None and view.linger:
                _log.info(
                    "simulated %.3f s in %.3f s wall; the live view stays at %s until Ctrl-C",
                    stats.sim_time,
                    stats.wall_time,
                    live.url,
                )
                with contextlib.suppress(KeyboardInterrupt):
                    while True:
                        time.sleep(1.0)
            return stats
        finally:
            if live is not None:
                live.close()
