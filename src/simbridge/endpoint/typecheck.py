"""Validation of message and service type names before they reach a backend."""

from __future__ import annotations

from typing import Protocol

from simbridge.messages import MessageRegistry, default_registry

__all__ = ["RegistryTypeCheck", "TypeCheck"]


class TypeCheck(Protocol):
    """Resolves type names; raises UnknownMessageTypeError for unknown ones."""

    def message(self, name: str) -> str:
        """Canonical `package/Type` of a message type."""

    def service(self, name: str) -> str:
        """Canonical `package/Service` of a service type."""


class RegistryTypeCheck:
    """TypeCheck backed by a message registry (the shared default one if none given)."""

    def __init__(self, registry: MessageRegistry | None = None) -> None:
        self._registry = registry if registry is not None else default_registry()

    def message(self, name: str) -> str:
        return self._registry.resolve(name)

    def service(self, name: str) -> str:
        return self._registry.service(name).name
