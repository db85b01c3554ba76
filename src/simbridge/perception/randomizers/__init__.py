"""Randomisers declared in a scene's `perception: randomizers:` list, applied in that order
to every frame; each module's docstring lists its keys and their ranges."""

from __future__ import annotations

from pathlib import Path

from simbridge.errors import did_you_mean
from simbridge.perception.camera import CameraSpec
from simbridge.perception.randomizers.base import Baseline, FrameState, Randomizer, frame_rng
from simbridge.perception.randomizers.camera_pose import CameraRandomizer, IntrinsicsRandomizer
from simbridge.perception.randomizers.distractors import DistractorsRandomizer
from simbridge.perception.randomizers.image_effects import BackgroundRandomizer, NoiseRandomizer
from simbridge.perception.randomizers.lights import LightsRandomizer
from simbridge.perception.randomizers.materials import MaterialsRandomizer
from simbridge.perception.randomizers.placement import HIDDEN_GROUP, PlacementRandomizer
from simbridge.perception.randomizers.robot_pose import RobotJointsRandomizer
from simbridge.perception.section import Section

__all__ = [
    "HIDDEN_GROUP",
    "RANDOMIZER_TYPES",
    "BackgroundRandomizer",
    "Baseline",
    "CameraRandomizer",
    "DistractorsRandomizer",
    "FrameState",
    "IntrinsicsRandomizer",
    "LightsRandomizer",
    "MaterialsRandomizer",
    "NoiseRandomizer",
    "PlacementRandomizer",
    "Randomizer",
    "RobotJointsRandomizer",
    "frame_rng",
    "parse_randomizer",
]

RANDOMIZER_TYPES = (
    "lights",
    "materials",
    "placement",
    "distractors",
    "robot_joints",
    "camera",
    "intrinsics",
    "background",
    "noise",
)


def parse_randomizer(
    section: Section, index: int, cameras: tuple[CameraSpec, ...], base_dir: Path
) -> Randomizer:
    """The randomiser of one `randomizers:` entry."""
    randomizer = _parse(section, index, cameras, base_dir)
    randomizer.where = section.where
    return randomizer


def _parse(
    section: Section, index: int, cameras: tuple[CameraSpec, ...], base_dir: Path
) -> Randomizer:
    kind = section.string("type", "")
    if kind not in RANDOMIZER_TYPES:
        raise section.error(
            f"unknown randomizer type {kind!r}{did_you_mean(kind, RANDOMIZER_TYPES)} "
            f"(valid: {', '.join(RANDOMIZER_TYPES)})",
            "type" if kind else None,
        )
    if kind == "lights":
        return LightsRandomizer(section)
    if kind == "materials":
        return MaterialsRandomizer(section, index)
    if kind == "placement":
        return PlacementRandomizer(section)
    if kind == "distractors":
        return DistractorsRandomizer(section, index, base_dir)
    if kind == "robot_joints":
        return RobotJointsRandomizer(section)
    if kind == "camera":
        return CameraRandomizer(section, {c.name: c.target for c in cameras})
    if kind == "intrinsics":
        return IntrinsicsRandomizer(section, [c.name for c in cameras])
    if kind == "background":
        return BackgroundRandomizer(section)
    return NoiseRandomizer(section)
