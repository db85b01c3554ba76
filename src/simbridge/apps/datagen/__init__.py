"""The datagen demo's scene: the pick-and-place table as a randomised perception dataset
(`simbridge demo datagen`, `simbridge datagen pick-and-place`, the perception benchmark)."""

from __future__ import annotations

from pathlib import Path

__all__ = ["SCENE"]

SCENE = Path(__file__).resolve().parent / "scene.yaml"
"""The scene file (shipped as package data)."""
