"""Simulation control services: pause/resume, step N, reset."""

from __future__ import annotations

import time
from typing import Any

from simbridge.connector import Connector
from simbridge.messages import MessageRegistry
from simbridge.sim.world.world import World

__all__ = ["STEP_SRV", "ControlServices"]

STEP_SRV = "simbridge_msgs/StepSimulation"
"""Shipped with the message definitions (so a separate endpoint process knows it too).
Request: how many physics steps to advance; response: sim time after them."""


class ControlServices:
    """`<prefix>/pause` (std_srvs/SetBool), `<prefix>/step` (StepSimulation) and
    `<prefix>/reset` (std_srvs/Empty), served to ROS through the connector."""

    def __init__(
        self,
        world: World,
        connector: Connector,
        prefix: str,
        registry: MessageRegistry | None = None,
        step_timeout: float = 30.0,
    ) -> None:
        self.world, self.connector, self._registry = world, connector, registry
        self.prefix = prefix.rstrip("/")
        self.step_timeout = step_timeout
        self._services: list[str] = []

    @property
    def registry(self) -> MessageRegistry:
        """Where responses come from: the registry given, else the connector's."""
        return self._registry or self.connector.registry

    def start(self) -> None:
        """Serve the three services."""
        for name, srv_type, handler in (
            ("pause", "std_srvs/SetBool", self._pause),
            ("step", STEP_SRV, self._step),
            ("reset", "std_srvs/Empty", self._reset),
        ):
            service = f"{self.prefix}/{name}"
            self.connector.implement_service(service, srv_type, handler)
            self._services.append(service)

    def close(self) -> None:
        """Stop serving."""
        for service in self._services:
            self.connector.unimplement_service(service)
        self._services.clear()

    def _pause(self, request: Any) -> Any:
        if request.data:
            # Reply once the step in progress is done, so the time quoted stays put.
            self.world.pause(wait=self.step_timeout)
        else:
            self.world.resume()
        state = "paused" if request.data else "running"
        return self.registry.new(
            "std_srvs/SetBoolResponse", success=True, message=f"{state} at t={self.world.time:.6f}"
        )

    def _step(self, request: Any) -> Any:
        steps = int(request.steps)
        if not self.world.paused:
            return self.registry.new(
                f"{STEP_SRV}Response",
                sim_time=self.world.time,
                success=False,
                message="pause the simulation first",
            )
        target = self.world.time + (steps - 0.5) * self.world.timestep
        self.world.request_steps(steps)
        deadline = time.monotonic() + self.step_timeout
        while self.world.time < target and time.monotonic() < deadline:
            time.sleep(0.0005)
        done = self.world.time >= target
        return self.registry.new(
            f"{STEP_SRV}Response",
            sim_time=self.world.time,
            success=done,
            message="" if done else f"stepping did not finish within {self.step_timeout} s",
        )

    def _reset(self, request: Any) -> Any:
        self.world.request_reset()
        return self.registry.new("std_srvs/EmptyResponse")
