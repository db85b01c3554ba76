"""Publish what the scene's sensors measure, polled after each physics step."""

from __future__ import annotations

from simbridge.connector import Connector
from simbridge.sim.sensors import SensorSuite
from simbridge.sim.world.world import World

__all__ = ["SensorPublisher"]


class SensorPublisher:
    """Advertises every sensor output and publishes the messages that fall due."""

    def __init__(self, world: World, connector: Connector, suite: SensorSuite) -> None:
        self.world, self.connector, self.suite = world, connector, suite
        self._callback: int | None = None

    def start(self) -> None:
        """Advertise the sensor topics and poll after every step; restart on world reset."""
        for topic, msg_type in self.suite.outputs.items():
            self.connector.register_publisher(topic, msg_type, queue_size=2)
        self._callback = self.world.add_step_callback(lambda world: self.poll())
        self.world.add_reset_callback(lambda world: self.suite.reset())

    def poll(self) -> None:
        """Publish every message due at the current sim time."""
        for publication in self.suite.poll(self.world.model, self.world.data):
            self.connector.publish(publication.topic, publication.message)

    def close(self) -> None:
        """Stop polling, unadvertise and release the sensors."""
        if self._callback is not None:
            self.world.remove_step_callback(self._callback)
            self._callback = None
        for topic in self.suite.outputs:
            self.connector.unregister_publisher(topic)
        self.suite.close()
