"""Record what a simulation publishes and receives into bags (MCAP or ROS 1), and replay them."""

from __future__ import annotations

from simbridge.sim.record.bagfile import BagFile, bag_kind
from simbridge.sim.record.player import PlayOptions, PlayStats, play, recorded_messages
from simbridge.sim.record.recorder import Recorder, RecordOptions, RecordStats

__all__ = [
    "BagFile",
    "PlayOptions",
    "PlayStats",
    "RecordOptions",
    "RecordStats",
    "Recorder",
    "bag_kind",
    "play",
    "recorded_messages",
]
