"""Package data shipped with simbridge (robot descriptions), located via importlib.resources."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

__all__ = ["asset_path", "robot_names", "robot_urdf"]

_ROBOTS_DIR = "robots"


def asset_path(relative: str) -> Path:
    """Return the filesystem path of a shipped asset, e.g. ``"robots/niryo_one.urdf"``."""
    path = Path(str(resources.files(__name__).joinpath(relative)))
    if not path.is_file():
        raise FileNotFoundError(f"no shipped asset {relative!r} under {path.parent}")
    return path


def robot_names() -> list[str]:
    """Names of the shipped robot descriptions (URDF file stems), sorted."""
    robots = resources.files(__name__).joinpath(_ROBOTS_DIR)
    return sorted(
        entry.name.removesuffix(".urdf")
        for entry in robots.iterdir()
        if entry.name.endswith(".urdf")
    )


def robot_urdf(name: str = "niryo_one") -> Path:
    """Path of a shipped robot URDF by name; the error lists the robots that exist."""
    if name not in robot_names():
        raise FileNotFoundError(f"unknown robot {name!r}; shipped robots: {robot_names()}")
    return asset_path(f"{_ROBOTS_DIR}/{name}.urdf")
