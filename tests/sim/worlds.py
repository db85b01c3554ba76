"""Scenes for the world tests, built in tmp_path around the sample URDFs."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

from simbridge.sim.scene import load_scene
from simbridge.sim.world import World
from tests.sim.urdf_samples import GRAVITY_ARM


def arm_scene(tmp_path: Path, scene: dict[str, Any]) -> Path:
    """Write GRAVITY_ARM as arm.urdf and `scene` as scene.yaml into `tmp_path`; the
    scene's path."""
    (tmp_path / "arm.urdf").write_text(GRAVITY_ARM)
    (tmp_path / "scene.yaml").write_text(yaml.safe_dump(scene))
    return tmp_path / "scene.yaml"


def arm_world(tmp_path: Path, **overrides: Any) -> World:
    """A world with GRAVITY_ARM at the origin; keyword overrides merge into the scene dict."""
    scene: dict[str, Any] = {
        "physics": {"timestep": 0.002, "realtime_factor": 0},
        "robots": [{"urdf": "arm.urdf"}],
        "ros": {"enabled": False},
    }
    for key, value in overrides.items():
        if isinstance(value, dict) and isinstance(scene.get(key), dict):
            scene[key] = {**scene[key], **value}
        elif key == "robot":
            scene["robots"][0].update(value)
        else:
            scene[key] = value
    return World.from_scene(load_scene(arm_scene(tmp_path, scene)))
