"""The `perception:` section of a scene: cameras, labelers, extra labels, render settings,
output settings and randomisers.

    perception:
      classes: [cube, robot, distractor]   # class id order (default: order of first use)
      labelers: [rgb, depth, semantic, instance, boxes_2d, boxes_3d, poses, keypoints]
      labels:                     # instances beyond the `label:` keys of objects and robots
        - {name: gripper, class: gripper, bodies: ["gripper_*"]}
      render: {quality: high, near: 0.01, far: 50, shadows: true, reflections: false}
                                  # (and multisamples, shadow_size: over the preset's)
      output: {depth_scale: 0.1, png_compression: 1, min_visible_px: 1, contact_sheet: 16}
      cameras:
        - {name: main, width: 640, height: 480, fovy: 60, eye: [1, 0.6, 0.7], target: [0, 0, 0]}
      randomizers: [...]          # see simbridge.perception.randomizers
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from simbridge.errors import PerceptionError, did_you_mean
from simbridge.perception.camera import CameraSpec
from simbridge.perception.randomizers import Randomizer, parse_randomizer
from simbridge.perception.render import QUALITIES, RenderSettings
from simbridge.perception.section import Section
from simbridge.sim.labels import BodyRule, parse_label_rules
from simbridge.sim.scene import Scene
from simbridge.sim.scene.located import Where

__all__ = ["LABELERS", "OutputSettings", "PerceptionConfig", "parse_perception"]

LABELERS = ("rgb", "depth", "semantic", "instance", "boxes_2d", "boxes_3d", "poses", "keypoints")


@dataclass(frozen=True)
class OutputSettings:
    """How files are written."""

    depth_scale: float = 0.1
    """BOP depth PNGs hold depth in mm divided by this (0.1: 0.1 mm steps, up to 6.5 m)."""
    png_compression: int = 1
    """zlib level of every PNG (1 is fast; 9 small and slow)."""
    min_visible_px: int = 1
    """Instances with fewer visible pixels get no COCO annotation (BOP lists them all)."""
    contact_sheet: int = 16
    """Frames shown on the contact sheet (0: none)."""


@dataclass(frozen=True)
class PerceptionConfig:
    """Everything the section declares."""

    cameras: tuple[CameraSpec, ...]
    labelers: frozenset[str]
    classes: tuple[str, ...]
    rules: tuple[BodyRule, ...]
    render: RenderSettings
    output: OutputSettings
    randomizers: tuple[Randomizer, ...]


def parse_perception(scene: Scene) -> PerceptionConfig:
    """Read `scene.perception`; errors name the scene file, line and entry."""
    source = str(scene.source) if scene.source is not None else None
    if scene.perception is None:
        raise PerceptionError(
            f"scene {source or '(from Python)'} has no 'perception:' section (cameras, "
            "labelers, randomizers); see docs/perception.md"
        )
    root = Section(
        scene.perception, Where("perception", source, getattr(scene.perception, "line", None))
    )
    cameras = tuple(CameraSpec.parse(s, i) for i, s in enumerate(root.items("cameras")))
    if not cameras:
        raise root.error("needs at least one entry under 'cameras'")
    names = [c.name for c in cameras]
    if len(set(names)) != len(names):
        raise root.error(f"camera names must differ, got {names}", "cameras")
    labelers = root.strings("labelers", LABELERS)
    for name in labelers:
        if name not in LABELERS:
            raise root.error(
                f"unknown labeler {name!r}{did_you_mean(name, LABELERS)} "
                f"(valid: {', '.join(LABELERS)})",
                "labelers",
            )
    render = root.sub("render")
    preset = QUALITIES[render.choice("quality", tuple(QUALITIES), "high")]
    settings = RenderSettings(
        near=render.number("near", 0.01, 1e-6),
        far=render.number("far", 50.0, 1e-3),
        shadows=render.boolean("shadows", preset.shadows),
        reflections=render.boolean("reflections", False),
        multisamples=render.integer("multisamples", preset.multisamples, low=0),
        shadow_size=(
            render.integer("shadow_size", 0, low=64, high=16384)
            if render.has("shadow_size")
            else preset.shadow_size
        ),
    )
    render.done(("quality", "near", "far", "shadows", "reflections", "multisamples", "shadow_size"))
    if settings.far <= settings.near:
        raise render.error(f"far {settings.far:g} must be beyond near {settings.near:g}", "far")
    output = root.sub("output")
    out = OutputSettings(
        depth_scale=output.number("depth_scale", 0.1, 1e-6),
        png_compression=output.integer("png_compression", 1, low=0),
        min_visible_px=output.integer("min_visible_px", 1, low=1),
        contact_sheet=output.integer("contact_sheet", 16, low=0),
    )
    output.done(("depth_scale", "png_compression", "min_visible_px", "contact_sheet"))
    if out.png_compression > 9:
        raise output.error(
            f"png_compression is a zlib level 0-9, got {out.png_compression}", "png_compression"
        )
    base_dir = scene.source.resolve().parent if scene.source is not None else Path.cwd()
    randomizers = tuple(
        parse_randomizer(s, i, cameras, base_dir) for i, s in enumerate(root.items("randomizers"))
    )
    config = PerceptionConfig(
        cameras=cameras,
        labelers=frozenset(labelers),
        classes=root.strings("classes"),
        rules=parse_label_rules(root.data.get("labels"), root.key("labels")),
        render=settings,
        output=out,
        randomizers=randomizers,
    )
    root.done(("cameras", "labelers", "classes", "labels", "render", "output", "randomizers"))
    return config
