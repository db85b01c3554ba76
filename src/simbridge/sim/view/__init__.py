"""A live 3D view of the simulation in the browser (`simbridge sim --view`), via viser."""

from __future__ import annotations

from simbridge.sim.view.live import LiveView, ViewOptions
from simbridge.sim.view.shapes import Shape, body_names, visual_shapes

__all__ = ["LiveView", "Shape", "ViewOptions", "body_names", "visual_shapes"]
