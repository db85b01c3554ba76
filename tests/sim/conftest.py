"""Fixtures of the sim tests."""

from __future__ import annotations

from collections.abc import Callable, Iterator

import pytest

from simbridge.sim.world import World
from tests.sim.bridged import BridgedWorld, bridge_world


@pytest.fixture
def bridged() -> Iterator[Callable[[World], BridgedWorld]]:
    """Bridges worlds to local endpoints of their own (see `bridge_world`); every rig is
    taken down after the test."""
    cleanup: list[Callable[[], None]] = []
    yield lambda world: bridge_world(world, cleanup)
    for undo in reversed(cleanup):
        undo()
