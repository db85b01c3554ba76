"""Publish what the scene's sensors measure, polled after each physics step.

Sensors are lazy: an output whose topic has no subscriber (as the endpoint reports
through its subscriber-count extension) is not measured at all. With an endpoint
that cannot report counts every output stays on.

Sensors build ROS 1 (noetic) messages; against a ROS 2 endpoint each one is translated
to the ROS 2 layout (Header without seq, CameraInfo `d k r p`) on its way out. IMU,
laser-scan and odometry messages skip that and the generic encoder: precompiled writers
serialize them for either generation (`sensor_encoder.py`).

Cameras with `labelers:` get the scene's label table here (the world knows the scene and
which bodies make each robot): their ids are those of a dataset of the same scene. Their
detections are built in the connector's layouts (noetic vision_msgs or 4.x), not translated.
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Sequence
from typing import Any, Protocol

import mujoco

from simbridge.connector import Connector, Publisher
from simbridge.messages import Translator, WireFormat, default_registry
from simbridge.sim.labels import scene_label_table
from simbridge.sim.ros.sensor_encoder import SensorEncoder
from simbridge.sim.sensors import Camera, Publication, SensorSuite
from simbridge.sim.world.callbacks import CallbackHandle
from simbridge.sim.world.world import World

__all__ = ["SensorObserver", "SensorPublisher"]


class SensorObserver(Protocol):
    """Another consumer of the sensors' messages (the live view): it may ask for topics
    nobody subscribes to, and is shown every batch of messages on the physics thread."""

    def wants(self, topic: str) -> bool:
        """Whether `topic` should be measured now for this observer."""

    def observe(self, publications: Sequence[Publication], data: mujoco.MjData) -> None:
        """The messages just measured, with the state they describe (must not block)."""


class SensorPublisher:
    """Advertises every sensor output and publishes the messages that fall due.

    `shared` names topics other publishers on the same connector also use (e.g. `/tf`):
    they stay registered on close and are always produced.
    """

    def __init__(
        self,
        world: World,
        connector: Connector,
        suite: SensorSuite,
        shared: Collection[str] = (),
    ) -> None:
        self.world, self.connector, self.suite = world, connector, suite
        self.shared = frozenset(shared)
        self._callbacks: list[CallbackHandle] = []
        self._lazy: dict[str, Publisher] = {}
        self._translator: Translator | None = None
        self._wire = SensorEncoder()
        """Precompiled writers for the hot kinds (IMU, laser scans, odometry and its TF)."""
        self.always_on = False
        """Measure every output even without subscribers (set while recording)."""
        self.observers: list[SensorObserver] = []
        self._next_due = (0, 0.0)
        """(step, at timestep) before which no sensor is due: `poll` skips until then."""
        self._bind_labels()

    def _bind_labels(self) -> None:
        """Give every labelling camera the scene's instance and class ids, and the connector's
        layouts for its detections (noetic's and vision_msgs 4.x's differ beyond renames)."""
        labelling = [s for s in self.suite.sensors if isinstance(s, Camera) and s.labeller.topics]
        if not labelling:
            return
        world = self.world
        bodies = {name: list(robot.bodies.values()) for name, robot in world.robots.items()}
        table = scene_label_table(world.model, world.scene, bodies)
        for camera in labelling:
            camera.bind_labels(table)
            camera.labeller.use_layouts(lambda: self.connector.registry)

    def add_observer(self, observer: SensorObserver) -> None:
        """Also measure what `observer` wants, and show it every batch of messages."""
        self.observers.append(observer)

    def start(self) -> None:
        """Advertise the sensor topics and poll after every step; restart on world reset."""
        for topic, msg_type in self.suite.outputs.items():
            lazy = topic not in self.shared
            publisher = self.connector.register_publisher(
                topic, msg_type, queue_size=2, report_subscribers=lazy
            )
            if lazy:
                self._lazy[topic] = publisher
        self._callbacks = [
            self.world.add_step_callback(lambda world: self.poll()),
            self.world.add_reset_callback(lambda world: self._restart()),
        ]

    def _restart(self) -> None:
        self.suite.reset()
        self._next_due = (0, 0.0)

    def publisher(self, topic: str) -> Publisher:
        """The connector publisher of a lazy output (its `subscriber_count` drives laziness)."""
        return self._lazy[topic]

    def poll(self) -> None:
        """Publish every message due at the current sim time, for outputs someone reads.

        Between two sensor ticks it returns at once (no per-sensor schedule checks)."""
        world = self.world
        step, timestep = world.step_count, world.timestep
        next_step, at_timestep = self._next_due
        if step < next_step and timestep == at_timestep:
            return
        try:
            self._poll()
        finally:
            sensors = self.suite.sensors
            nearest = min((s.schedule.next_step(timestep) for s in sensors), default=step + 1)
            self._next_due = (nearest, timestep)

    def _poll(self) -> None:
        for topic, publisher in self._lazy.items():
            wanted = self.always_on or publisher.has_subscribers
            self.suite.set_wanted(topic, wanted or any(o.wants(topic) for o in self.observers))
        publications = self.suite.poll(self.world.model, self.world.data, self.world.refresh)
        if not publications:
            return
        for observer in self.observers:
            observer.observe(publications, self.world.data)
        connector = self.connector
        fmt: WireFormat = "cdr" if connector.wire_format == "cdr" else "ros1"
        wire = (fmt, connector.registry.protocol == "ROS1")
        translate = self._translate()
        for publication in publications:
            payload = self._wire.encode(publication, wire)
            if payload is not None:
                connector.publish(publication.topic, payload)
                continue
            message = publication.message
            connector.publish(
                publication.topic, message if translate is None else translate(message)
            )

    def _translate(self) -> Callable[[Any], Any] | None:
        """Conversion into the connector's layouts; None when they are the sensors' own."""
        target, source = self.connector.registry, default_registry()
        if target is source:
            return None
        if self._translator is None or self._translator.dst is not target:
            self._translator = Translator(source, target)
        return self._translator.translate

    def close(self) -> None:
        """Stop polling (after steps and resets), unadvertise and release the sensors."""
        for callback in self._callbacks:
            callback.remove()
        self._callbacks.clear()
        for topic in self._lazy:
            self.connector.unregister_publisher(topic)
        self._lazy.clear()
        self.suite.close()
