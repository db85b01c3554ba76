"""A live 3D view of the simulation in the browser (`simbridge sim --view`), via viser."""

from __future__ import annotations

from simbridge.sim.view.controls import SimControls, joint_slider_ranges
from simbridge.sim.view.follow import CameraFollow, follow_targets
from simbridge.sim.view.framing import MIN_DISTANCE, Framing, framing
from simbridge.sim.view.live import LiveView, ViewOptions
from simbridge.sim.view.mover import ObjectMover, free_bodies, place_body
from simbridge.sim.view.overlays import CONTACT_RGB, ContactPoints, TfFrames
from simbridge.sim.view.sensors import LIDAR_RGB, SensorFeed
from simbridge.sim.view.shapes import Shape, body_names, visual_shapes

__all__ = [
    "CONTACT_RGB",
    "LIDAR_RGB",
    "MIN_DISTANCE",
    "CameraFollow",
    "ContactPoints",
    "Framing",
    "LiveView",
    "ObjectMover",
    "SensorFeed",
    "Shape",
    "SimControls",
    "TfFrames",
    "ViewOptions",
    "body_names",
    "follow_targets",
    "framing",
    "free_bodies",
    "joint_slider_ranges",
    "place_body",
    "visual_shapes",
]
