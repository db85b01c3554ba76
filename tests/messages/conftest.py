"""Shared fixtures: the default registry (read-only use) and fresh ones to mutate."""

from __future__ import annotations

import pytest

from simbridge.messages import MessageRegistry, default_registry


@pytest.fixture(scope="session")
def registry() -> MessageRegistry:
    """The shared default registry; tests must not add types to it."""
    return default_registry()


@pytest.fixture
def fresh_registry() -> MessageRegistry:
    """A private registry a test may extend."""
    return MessageRegistry()
