"""The rig of the sim's ROS tests: a world bridged to a local endpoint of its own, running
at real time, with an in-process node on the endpoint's bus to talk to it."""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass, field

from simbridge.connector import Connector, ConnectorOptions
from simbridge.endpoint import EndpointOptions, EndpointThread, LocalBus, Node
from simbridge.sim.ros import SimRosBridge
from simbridge.sim.world import World

__all__ = ["BridgedWorld", "bridge_world"]


@dataclass
class BridgedWorld:
    """A running world, its endpoint, the sim's connection and bridge, and `node`
    ("/tester" on the endpoint's local bus)."""

    endpoint: EndpointThread
    sim: Connector
    world: World
    bridge: SimRosBridge
    node: Node
    cleanup: list[Callable[[], None]] = field(repr=False)
    """What undoes the rig, run last to first."""

    def connect(self) -> Connector:
        """Another client of the endpoint, closed with the rig."""
        connector = Connector("127.0.0.1", self.endpoint.port, ConnectorOptions()).connect(wait=5)
        self.cleanup.append(connector.close)
        return connector


def bridge_world(world: World, cleanup: list[Callable[[], None]]) -> BridgedWorld:
    """Bridge `world` to a new local endpoint and run it at real time; everything made is
    undone by running `cleanup` last to first (also when this fails halfway)."""
    endpoint = EndpointThread(EndpointOptions(port=0)).start()
    cleanup.append(endpoint.stop)
    sim = Connector("127.0.0.1", endpoint.port, ConnectorOptions()).connect(wait=5)
    cleanup.append(sim.close)
    bridge = SimRosBridge(world, sim).start()
    cleanup.append(bridge.close)
    assert isinstance(endpoint.backend, LocalBus)
    node = Node(endpoint.backend, "/tester")
    cleanup.append(node.close)
    assert sim.flush(5)
    sim.endpoint_stats()  # a barrier: the endpoint holds the bridge's topics and services
    runner = threading.Thread(target=world.run, kwargs={"realtime_factor": 1.0})
    runner.start()
    cleanup.append(lambda: runner.join(5))
    cleanup.append(world.stop)
    return BridgedWorld(endpoint, sim, world, bridge, node, cleanup)
