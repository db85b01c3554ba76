"""A camera's offscreen renderer, opened on first use: an unwatched camera opens no GL context."""

from __future__ import annotations

from collections.abc import Callable

import mujoco

from simbridge.sim.sensors.offscreen import OffscreenRenderer

__all__ = ["LazyRenderer"]


class LazyRenderer:
    """Opens its renderer with `factory` when first asked for it, and frees it on `close`."""

    def __init__(self, factory: Callable[[mujoco.MjModel], OffscreenRenderer]) -> None:
        self._factory = factory
        self._renderer: OffscreenRenderer | None = None

    def get(self, model: mujoco.MjModel) -> OffscreenRenderer:
        """The renderer, opened for `model` on the first call."""
        if self._renderer is None:
            self._renderer = self._factory(model)
        return self._renderer

    def close(self) -> None:
        """Free the renderer if it was opened; a later `get` opens a new one."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
